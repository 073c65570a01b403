"""The campaign file an import writes: the joined campaign as CSV text (the format
:func:`vecpin.measurement.campaign.write_campaign` reads back), staged and read back
before it replaces anything."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from vecpin.errors import CampaignFileError
from vecpin.kinematics.machine import Machine
from vecpin.measurement.campaign import Campaign
from vecpin.measurement.importer import ImportResult
from vecpin.units import M_PER_MM


def campaign_text(campaign: Campaign, machine: Machine) -> str:
    """A campaign as CSV text in the format :func:`vecpin.measurement.campaign.write_campaign`
    writes (mm, deg; 6 decimals in mm, 8 in deg), extra columns after x, y, z."""
    q_user = machine.to_user(campaign.q)
    nests = len(campaign.nest_rows) > 0  # then also which rows read a table nest, and which
    several = bool(np.any(campaign.station != 0))  # and from which tracker station
    header = machine.axis_names + ["tool", "x", "y", "z"] + list(campaign.extra) + (["instrument", "target"] if nests else []) \
        + (["station"] if several else [])
    fmts = ["%.6f" if a.kind == "linear" else "%.8f" for a in machine.axes] + ["%.6f"] * 4
    cols = [q_user[:, j] for j in range(machine.n_axes)] + [campaign.tool / M_PER_MM] + \
        [campaign.xyz[:, k] / M_PER_MM for k in range(3)]
    extra_fmt = ["%d" if k == "point" or k.startswith("approach_") else "%.6f" for k in campaign.extra]
    lines = [",".join(header)]
    for i in range(len(campaign)):
        cells = [f % c[i] for f, c in zip(fmts, cols)] + \
                [f % v[i] for f, v in zip(extra_fmt, campaign.extra.values())]
        if nests:
            cells += [str(campaign.instrument[i]), str(campaign.target[i])]
        if several:
            cells.append(str(int(campaign.station[i])))
        lines.append(",".join(cells))
    return "\n".join(lines) + "\n"


def write_imported(result: ImportResult | Campaign, machine: Machine, path: str | Path) -> Path:
    """Write the campaign CSV of an import (or a campaign) and read it back with
    :func:`read_campaign` (the check every campaign file passes)."""
    from vecpin.fileio import OutputSet
    from vecpin.measurement.campaign import read_campaign
    path = Path(path)
    with OutputSet(path.parent) as out:  # committed only when it reads back
        staged = out.path(path.name)
        campaign = result if isinstance(result, Campaign) else result.campaign
        staged.write_text(campaign_text(campaign, machine), encoding="utf-8")
        try:
            read_campaign(staged, machine)
        except CampaignFileError as exc:
            reason = exc.reason.replace(str(staged), str(path))  # the file as it would be written, not its staging copy
            raise CampaignFileError(path, f"the imported campaign would not be readable ({reason}); nothing was "
                                    "written", exc.row, exc.column) from None
    return path
