"""vecpin: volumetric error compensation of multi-axis machine tools (Pinocchio-based).

The main path, as the command line runs it::

    import vecpin
    m = vecpin.Machine.load("flow_xyzcb")
    campaign = vecpin.read_campaign("campaign.csv", m)
    run = vecpin.fit(m, campaign, vecpin.NoiseModel.default(m, "spherical"))   # the data choose the model
    tables = vecpin.plan_tables(run.model).tables                             # a TableSet
    vecpin.make_tables(run.model, "tables", "siemens-840d", profile="profile.json")

The same fit as an estimator (scikit-learn's ``RidgeCV`` pattern: the model choice inside
``fit``), with the predicted tool-tip error and its standard deviation::

    est = vecpin.ErrorModelCV(m).fit(campaign)          # est.model_, est.choice_
    error, std = est.predict(q, tool, return_std=True)  # tip error (N,3) m, relative to the workpiece

The same fit as a problem and its solution (what both of the above run)::

    result = vecpin.FitProblem.build(m, campaign, kind="6dof").solve()   # a frozen FitResult

Names are imported when first used (PEP 562), so ``import vecpin`` and the command line's help
do not load Pinocchio and SciPy until a command needs them.
"""
from __future__ import annotations

import importlib

FACADE = "vecpin.workflows.facade"   # the library's functions, their arguments checked (a path, a name or an object)
_NAMES = {
    "Machine": "vecpin.kinematics.machine", "Axis": "vecpin.kinematics.axes",
    "bundled_machines": "vecpin.kinematics.axes",
    "Campaign": "vecpin.measurement.campaign", "read_campaign": FACADE, "write_campaign": FACADE,
    "VecpinError": "vecpin.errors", "MachineError": "vecpin.errors", "CampaignFileError": "vecpin.errors",
    "ErrorModel": "vecpin.models", "SixDofModel": "vecpin.models", "APModel": "vecpin.models",
    "make_model": FACADE, "ModelSpec": "vecpin.models.spec", "NoiseModel": "vecpin.measurement.noise",
    "ErrorModelCV": "vecpin.fitting.estimator", "FitProblem": "vecpin.fitting.problem",
    "FitResult": "vecpin.fitting.problem",
    "fit": ("vecpin.workflows.fitting", "fit_campaign"), "simulate": FACADE,
    "plan_tables": FACADE, "TableSet": "vecpin.compensation.tables",
    "make_tables": FACADE, "diagnose": FACADE,
}
__all__ = sorted(_NAMES) + ["__version__"]


def __getattr__(name: str):
    if name == "__version__":
        from importlib.metadata import PackageNotFoundError, version
        try:
            return version("vecpin")
        except PackageNotFoundError:
            return "unknown (not installed)"
    target = _NAMES.get(name)
    if target is None:
        raise AttributeError(f"module 'vecpin' has no attribute '{name}'")
    module, attr = target if isinstance(target, tuple) else (target, name)
    found = importlib.import_module(module)
    value = found.facade(attr) if module == FACADE else getattr(found, attr)   # the facade: per name (facade.facade)
    globals()[name] = value
    return value


def __dir__():
    return __all__
