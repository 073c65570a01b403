"""The campaign file an import writes: the joined campaign as CSV text
(:func:`vecpin.measurement.campaign.campaign_text`, the one writer of campaign files),
staged and read back before it replaces anything."""
from __future__ import annotations

from pathlib import Path

from vecpin.errors import CampaignFileError
from vecpin.kinematics.machine import Machine
from vecpin.measurement.campaign import Campaign, campaign_text, read_campaign
from vecpin.measurement.importer import ImportResult


def write_imported(result: ImportResult | Campaign, machine: Machine, path: str | Path) -> Path:
    """Write the campaign CSV of an import (or a campaign) and read it back with
    :func:`read_campaign` (the check every campaign file passes)."""
    from vecpin.fileio import OutputSet
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
