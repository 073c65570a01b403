"""Error models: bases, the 6-DoF and AP models, effects as model terms, model files.

``SixDofModel(machine, order).fit(campaign)`` identifies a model; ``make_model(kind,
machine, order)`` builds one by name; ``ErrorModel.from_spec(machine, spec)`` from its
:class:`ModelSpec`; ``ErrorModel.load(path)`` reads a model file.
"""
from vecpin.models.base import MODELS, ErrorModel, make_model, register_model
from vecpin.models.sixdof import COMPONENTS, SixDofModel  # registered first: the model choice's first kind
from vecpin.models.ap import APModel
from vecpin.models.parameters import Parameter
from vecpin.models.spec import ModelSpec
from vecpin.models.tips import ModelTip

__all__ = ["APModel", "COMPONENTS", "ErrorModel", "MODELS", "ModelSpec", "ModelTip", "Parameter", "SixDofModel",
           "make_model", "register_model"]
