"""The 3D scene of measured against modelled tool tips (the ``view`` command): the
model's tables for the compensated group, then the meshcat scene as a page or a server
(:mod:`vecpin.viz.scene`)."""
from __future__ import annotations

from pathlib import Path
from typing import Callable

from vecpin.compensation.plan import plan_tables
from vecpin.errors import InputError
from vecpin.fileio import check_output_file
from vecpin.measurement.campaign import Campaign
from vecpin.models import ErrorModel
from vecpin.viz.scene import serve, write_html

SCENE_COMMANDS = 400   # pseudo-commands of the generic tables the compensated group shows


def view(model: ErrorModel, campaign: Campaign, *, row: int | None = None, exaggerate=None, show: str = "errors",
         no_tables: bool = False, html: str | Path | None = None,
         ready: Callable[[str, dict], None] | None = None) -> dict | None:
    """The scene of ``model`` on ``campaign`` posed at ``row`` (the campaign file's row as
    messages count it: header = 1, first measurement row 2; None: the first row drawn): written to the page
    ``html`` (returns the scene's facts), or served until Ctrl-C with ``ready(url, facts)``
    called once it is up (returns None). ``no_tables``: no compensated group (the
    generic tables of the model are not computed); ``exaggerate``, ``show``: as
    :func:`vecpin.viz.scene.build_scene`."""
    if html is not None:
        check_output_file(html, "html")
    if show == "compensated" and no_tables:
        raise InputError("`show` compensated needs the tables: drop `no_tables`")
    tables = None if no_tables else plan_tables(model, n_commands=SCENE_COMMANDS).tables
    if html is not None:
        return write_html(html, model, campaign, row, exaggerate, tables, show)
    serve(model, campaign, row, exaggerate, tables, ready, show)
    return None
