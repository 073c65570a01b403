"""The machines shipped with vecpin (``robots/``): their names and URDF paths, read without
loading Pinocchio (the workbench's page lists them before any machine is loaded)."""
from __future__ import annotations

from importlib import resources
from pathlib import Path


def bundled_machines() -> list[str]:
    """Names of the machines shipped in ``robots/``."""
    return sorted(p.name[:-5] for p in resources.files("vecpin.robots").iterdir() if p.name.endswith(".urdf"))


def _bundled_path(name: str) -> Path | None:
    res = resources.files("vecpin.robots").joinpath(name + ".urdf")
    return Path(str(res)) if res.is_file() else None
