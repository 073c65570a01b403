"""The diagnosis's three sentences say one thing: what is left after an accepted effect is
said as left after it, not as a contradiction of it."""
import numpy as np

from vecpin.diagnosis.result import Diagnosis, EffectScore


def _diagnosis(flow, accepted: bool) -> Diagnosis:
    e = EffectScore("rotary_periodic", "rotary_periodic[C]", ["C"], 4, 120.0, 30.0, 1e-9, 1e-3,
                    0.020, 0.012, 0.060, 0.040, significant=accepted, accepted=accepted)
    return Diagnosis(flow, {"label": "6-DoF order 4", "heldout_mean_mm": 0.020}, [e], [],
                     {"breakdowns": {}, "most_structured": []}, None, None, np.zeros((0, 3)), None, 1.0,
                     best=(0.012 if accepted else 0.020, 0.040),
                     localization_final={"breakdowns": {"C": {"coordinate": "C"}}}, unexplained=["C"])


def test_structure_left_after_the_accepted_effect_is_said_as_left_after_it(flow):
    which, todo = _diagnosis(flow, True).headline()[1:]
    assert "rotary_periodic[C]" in which and "explains it" in which
    assert "Not explained by any candidate" not in todo
    assert "Left after rotary_periodic[C]: structure along C that no candidate explains." in todo
    _, todo = _diagnosis(flow, False).headline()[1:]
    assert "Left: structure along C that no candidate explains." in todo
