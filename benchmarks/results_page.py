"""A benchmark's results page: printed, and written under docs/results/ (shared by the benches)."""
from __future__ import annotations

from pathlib import Path


def publish(text: str, path: str | Path, write: bool = True) -> None:
    """Print the page ``text`` and, with ``write``, write it to ``path`` (its folder made), saying so."""
    print(text)
    if not write:
        return
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
    print(f"wrote {path}")
