"""Error models: bases, the 6-DoF and AP models, effects as model terms, model files.

``SixDofModel(machine, order).fit(campaign)`` identifies a model; ``make_model(kind,
machine, order)`` builds one by name; ``ErrorModel.load(path)`` reads a model file.
"""
from vecpin.models.ap import APModel
from vecpin.models.base import MODELS, ErrorModel, ModelTip, make_model, register_model
from vecpin.models.parameters import Parameter
from vecpin.models.sixdof import COMPONENTS, SixDofModel

__all__ = ["APModel", "COMPONENTS", "ErrorModel", "MODELS", "ModelTip", "Parameter", "SixDofModel", "make_model",
           "register_model"]
