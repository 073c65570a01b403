"""The fit's settings and their defaults: one table (:data:`DEFAULTS`), read by
:class:`~vecpin.fitting.problem.FitProblem`, :class:`~vecpin.fitting.estimator.ErrorModelCV`
and the ``fit`` command's options. Plain Python: reading it imports nothing heavy."""
from __future__ import annotations

# The fit's settings: name -> (default, meaning). The one table of defaults: FitProblem's fields,
# ErrorModelCV's constructor and the command line's options take theirs from here.
DEFAULTS: dict[str, tuple[object, str]] = {
    "kind": ("auto", "the model kind: \"6dof\" (Paper I eq. 3-6), \"ap\" (eq. 7-8) or \"auto\" (chosen on held-out "
                     "data)"),
    "basis": ("auto", "the basis of the error functions (chebyshev, fourier, fourier_trend, spline, pspline), "
                      "\"auto\": chosen per axis on held-out data, or \"smooth\": rich bases with a smoothness "
                      "prior whose scales the evidence chooses"),
    "order": ("auto", "the series order (a whole number; the interior knots of a spline basis) or \"auto\": chosen "
                      "per axis on held-out data"),
    "tool_corrections": (False, "also fit a length correction per tool [mm] (default: the gauge line T_offset only)"),
    "prior_scale": (1.0, "factor on every parameter's prior standard deviation, > 0"),
    "underdetermined": (False, "accept fewer equations than unknowns, the priors deciding the rest"),
    "cv": (5, "the model choice's cross-validation: a number of folds (rows of one command share a fold) or one "
              "fold label per row (rows with the same label are held out together)"),
    "zone": (None, "fit only the rows commanded in this box {axis: (low, high)} [mm/deg]; the model records it"),
    "noise_from_data": (None, "take the noise level from the data (None: when the noise states no level: None or an "
                              "instrument's name)"),
    "nest_heights": (None, "{nest id: height [mm] of its reflector centre above the table's face, or (height, its "
                           "standard deviation) [mm]} (three or more; default standard deviation a height gauge's)"),
    "table_face": (None, "{linear axis: (distance [mm], the indicator's change [µm], + when pushed in as the "
                         "command increases) or (distance, change, its standard deviation [µm])}: the table face's "
                         "parallelism read with a dial test indicator swept along X and Y, the rotary axes at zero "
                         "(default standard deviation 2 µm)"),
}


def default(name: str):
    """The default of the fit setting ``name`` (:data:`DEFAULTS`)."""
    return DEFAULTS[name][0]
