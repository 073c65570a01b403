from vecpin.kinematics.machine import Machine, Axis, bundled_machines
from vecpin.measurement.campaign import Campaign, read_campaign, write_campaign
from vecpin.errors import CampaignFileError, MachineError, VecpinError
from vecpin.models import APModel, ErrorModel, SixDofModel, make_model
from vecpin.measurement.noise import NoiseModel

__all__ = ["Machine", "Axis", "bundled_machines", "Campaign", "read_campaign", "write_campaign",
           "VecpinError", "MachineError", "CampaignFileError", "ErrorModel", "SixDofModel", "APModel",
           "make_model", "NoiseModel"]
