"""Where the residual lies, which effect causes it, how far it shrinks (the ``diagnose``
command): :func:`vecpin.diagnosis.diagnose.diagnose` on a campaign, its files written
into one folder."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from vecpin.diagnosis.result import Diagnosis
from vecpin.errors import InputError
from vecpin.fileio import check_output_dir
from vecpin.kinematics.machine import Machine
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.instruments.multilateration import check_stations
from vecpin.measurement.noise import NoiseModel
from vecpin.measurement.nestheights import check_heights_before_fit, with_nest_heights
from vecpin.measurement.tableface import with_table_face
from vecpin.planning.zones import Zone, clip_to_zone
from vecpin.fitting.problem import check_face_readings, zone_rows


@dataclass
class DiagnoseRun:
    """The diagnosis and the files written (diagnosis.json, the two model files, report.md; its figures beside it)."""

    diagnosis: Diagnosis
    files: list[Path]

    def lines(self) -> list[str]:
        return ([self.diagnosis.summary()] + [f"wrote {p}" for p in self.files]
                + [f"diagnosis took {self.diagnosis.seconds:.1f} s"])


def diagnose_to_dir(machine: Machine, campaign: Campaign, out: str | Path, noise: NoiseModel | None = None, *,
                    model: str = "auto", basis: str = "auto", order: int | str = "auto",
                    effects: str | Sequence[str] = "all", folds: int = 5, alpha: float = 0.01,
                    progress: Callable[[str], None] | None = None, base: str | Path | None = None,
                    zone: Zone | None = None, nest_heights: dict | None = None,
                    table_face: dict | None = None) -> DiagnoseRun:
    """Diagnose ``campaign`` and write the result into the folder ``out``. ``effects``:
    "all", effect names, or their comma list; ``noise`` default: the tracker's spherical model
    (:meth:`NoiseModel.default`); ``base``: a model file (``fit``'s model.json) whose kind,
    bases and orders are the base model, so the model choice is not repeated; ``folds``,
    ``alpha``, ``model``, ``basis``, ``order`` as :func:`vecpin.diagnosis.diagnose.diagnose`;
    ``zone``: diagnose only the rows commanded in it, for a model used there only (the
    model files record it, as ``fit``'s do); ``nest_heights``: {nest id: height [mm] of its
    reflector centre above the table's face, or (height, its standard deviation) [mm]}, carried
    by both model files as ``fit``'s model carries them (the tables then keep the table's face);
    ``table_face``: the indicator's sweeps of the face, as ``fit``'s setting, carried alike.
    The folder, the model file and the folds are checked before any fit, with the effects;
    ``folds`` and ``alpha`` by the diagnosis itself."""
    from vecpin.diagnosis.diagnose import diagnose
    from vecpin.models.base import ErrorModel
    check_output_dir(out, "out")
    effects = _effect_names(effects)
    base_model = None if base is None else ErrorModel.load(base)
    noise = noise or NoiseModel.default(machine)
    if noise.instrument == "range":
        check_stations(campaign)
    check_heights_before_fit(nest_heights, campaign)   # ids and heights before any fit, the nests' line after it
    check_face_readings(table_face, nest_heights, machine)
    if zone:
        campaign = zone_rows(machine, campaign, zone)
    drawing = _Drawing()
    try:
        d = diagnose(machine, campaign, model=model, order=order, effects=effects, noise=noise, folds=folds,
                     alpha=alpha, basis=basis, progress=progress, base=base_model,
                     travel=clip_to_zone(machine, zone) if zone else None, base_known=drawing.start)
        for fitted in (d.base_model, d.best_model):
            if zone:
                fitted.zone_ = dict(zone)
            fitted.setup_ = with_table_face(with_nest_heights(fitted.setup_, nest_heights), table_face, machine)
        return DiagnoseRun(d, [Path(p) for p in d.write(out, draw=drawing.finish).values()])
    finally:
        drawing.close()


def _figures(early):
    """The report's figures in two steps (:class:`vecpin.threads.Background`): the base
    model's from ``early`` (a :class:`~vecpin.diagnosis.report.DiagnosisFigures`) at once,
    then the effects' from the whole figure data handed later (the base model's drawn again
    if they differ from ``early``); PNG bytes by figure key. matplotlib is imported here,
    in the drawing process only."""
    from vecpin.viz.diagnosis import draw_base, draw_effects, same_base
    pngs = draw_base(early) if early is not None else None
    data = yield
    if pngs is None or not same_base(early, data):
        pngs = draw_base(data)
    yield pngs | draw_effects(data)


class _Drawing:
    """The diagnosis' figures drawn beside it: started in a forked process as soon as the
    base model's breakdowns, held-out residuals and outliers are final
    (:func:`vecpin.diagnosis.diagnose.diagnose`'s ``base_known``), while the diagnosis
    goes on; the effects' figure and the files when the diagnosis is written."""

    def __init__(self):
        self._bg = None

    def start(self, localization: dict, heldout: np.ndarray, outliers: np.ndarray) -> None:
        """The base model's figures started (``heldout`` [m] per row, ``outliers`` rows)."""
        from types import SimpleNamespace
        from vecpin.diagnosis.report import figure_data
        from vecpin.threads import Background
        early = figure_data(SimpleNamespace(localization=localization, heldout_base=heldout, outlier_rows=outliers,
                                            effects=[]))   # the fields figure_data reads of a Diagnosis
        self.close()
        self._bg = Background(_figures, early)

    def finish(self, data, out) -> dict[str, Path]:
        """The figures of ``data`` (the whole figure data) written into ``out`` (an output set)."""
        from vecpin.diagnosis.report import FIGURES
        from vecpin.threads import Background
        bg, self._bg = self._bg or Background(_figures, None), None
        return {k: out.write_bytes(FIGURES[k], png) for k, png in bg.finish(data).items()}

    def close(self) -> None:
        if self._bg is not None:
            self._bg.close()
            self._bg = None


def _effect_names(effects: str | Sequence[str]) -> str | list[str]:
    """"all", or the named effects (a list or a comma list), each one registered."""
    from vecpin.models.effects import REGISTRY
    if effects == "all":
        return "all"
    text = effects if isinstance(effects, str) else ",".join(effects)
    names = [e.strip() for e in text.split(",") if e.strip()]
    unknown = [e for e in names if e not in REGISTRY]
    if not names or unknown:
        raise InputError(f"`effects` '{text}': 'all' or a comma list of effect names"
                         + (f"; unknown effect '{unknown[0]}'" if unknown else "") + f" (known: {', '.join(REGISTRY)})")
    return names
