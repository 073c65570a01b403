from .machine import Machine, Axis, bundled_machines
from .campaign import Campaign, read_campaign, write_campaign
from .errors import CampaignFileError, MachineError, VecpinError
from .models import APModel, ErrorModel, SixDofModel, make_model
from .noise import NoiseModel

__all__ = ["Machine", "Axis", "bundled_machines", "Campaign", "read_campaign", "write_campaign",
           "VecpinError", "MachineError", "CampaignFileError", "ErrorModel", "SixDofModel", "APModel",
           "make_model", "NoiseModel"]
