"""The README's settings table lists every setting the service reads, and nothing else."""

from __future__ import annotations

import re
from pathlib import Path

from core.settings import Settings

README = Path(__file__).resolve().parents[2] / "README.md"


def test_every_setting_is_in_the_readme() -> None:
    section = README.read_text().split("## Settings", 1)[1].split("\n## ", 1)[0]
    listed = set(re.findall(r"^\| `DEPOT_([A-Z0-9_]+)` \|", section, re.M))
    assert listed == {name.upper() for name in Settings.model_fields}
