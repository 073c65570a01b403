"""Error models: bases, 6-DoF and AP models, effects as model terms, model files."""
from vecpin.models.base import APModel, ErrorModel, Parameter, SixDofModel, make_model

__all__ = ["APModel", "ErrorModel", "Parameter", "SixDofModel", "make_model"]
