"""The Python facade's arguments checked where a script hands them over (``vecpin.plan_tables``,
``vecpin.make_tables``, ``vecpin.diagnose``, ``vecpin.simulate``, ``vecpin.read_campaign``,
``vecpin.write_campaign``, ``vecpin.make_model``): a path or a name where an object is taken
is read as the command line reads it (a model file, a bundled machine, a campaign CSV),
anything else refused naming the argument and what it takes, never an error deep inside.

Each function here is the library's own function (same signature, same text, given by
:func:`facade` when ``vecpin.<name>`` is first used: only that function's module imported),
its arguments converted first; ``vecpin.fit`` does the same in
:func:`vecpin.fitting.problem.fit_arguments`."""
from __future__ import annotations

import functools
import importlib
from pathlib import Path

from vecpin.errors import InputError
from vecpin.kinematics.machine import as_machine

PATH = (str, Path)


def _real(module: str, name: str):
    """The library's function, looked up by name when called (its module imported by :func:`facade` already)."""
    return getattr(importlib.import_module(module), name)


def facade(name: str):
    """The facade's function ``name`` with the library function's text and signature (functools.wraps), that
    function's module imported now: the first time ``vecpin.<name>`` is used, not with the facade's other names
    (their seven modules together cost a script's first facade call about 3 s of CPU, one of them 0.7 s)."""
    fn = globals()[name]
    return fn if hasattr(fn, "__wrapped__") else functools.update_wrapper(fn, _real(_LIBRARY[name], name))


def as_model(model, name: str = "model"):
    """A fitted :class:`ErrorModel`, or the path of a model file (read); else refused."""
    from vecpin.models import ErrorModel
    if isinstance(model, PATH):
        return ErrorModel.load(model)
    if not isinstance(model, ErrorModel):
        raise InputError(f"`{name}` {type(model).__name__}: give a fitted ErrorModel or the path of a model file "
                         "(model.json)")
    return model


def _path(path, name: str):
    if not isinstance(path, PATH) or not str(path):
        raise InputError(f"`{name}` {path!r}: give a file path")
    return path


PLAN, TABLES, DIAGNOSE = "vecpin.compensation.plan", "vecpin.workflows.tables", "vecpin.diagnosis.diagnose"
SIMULATE, CAMPAIGN, MODELS = "vecpin.simulation.simulate", "vecpin.measurement.campaign", "vecpin.models"
_LIBRARY = {"plan_tables": PLAN, "make_tables": TABLES, "diagnose": DIAGNOSE, "simulate": SIMULATE,
            "read_campaign": CAMPAIGN, "write_campaign": CAMPAIGN, "make_model": MODELS}   # each name's module


def plan_tables(model, *args, **kw):
    return _real(PLAN, "plan_tables")(as_model(model), *args, **kw)


def make_tables(model, out_dir, *args, profile=None, **kw):
    from vecpin.export.profile import ControllerProfile
    if profile is not None and not isinstance(profile, PATH + (ControllerProfile,)):
        raise InputError(f"`profile` {type(profile).__name__}: give a ControllerProfile or the path of a profile "
                         "file (JSON)")
    return _real(TABLES, "make_tables")(as_model(model), _path(out_dir, "out_dir"), *args, profile=profile, **kw)


def diagnose(machine, campaign, *args, noise=None, base=None, **kw):
    from vecpin.fitting.problem import fit_arguments
    machine, campaign, converted = fit_arguments(machine, campaign, noise)
    base = None if base is None else as_model(base, "base")
    return _real(DIAGNOSE, "diagnose")(machine, campaign, *args, noise=None if noise is None else converted, base=base,
                                       **kw)


def simulate(machine, seed=0, *args, **kw):
    if isinstance(seed, bool) or not isinstance(seed, int):
        raise InputError(f"`seed` {seed!r}: a whole number")
    return _real(SIMULATE, "simulate")(as_machine(machine), seed, *args, **kw)


def read_campaign(path, machine):
    return _real(CAMPAIGN, "read_campaign")(_path(path, "path"), as_machine(machine))


def write_campaign(path, campaign, machine):
    from vecpin.measurement.campaignrows import Campaign
    if not isinstance(campaign, Campaign):
        raise InputError(f"`campaign` {type(campaign).__name__}: give a Campaign (vecpin.read_campaign reads one)")
    return _real(CAMPAIGN, "write_campaign")(_path(path, "path"), campaign, as_machine(machine))


def make_model(kind, machine, *args, **kw):
    return _real(MODELS, "make_model")(kind, as_machine(machine), *args, **kw)
