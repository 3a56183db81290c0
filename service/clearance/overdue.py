"""A run whose arrival never comes, with no train behind it: when a dispatcher may act on it."""

from __future__ import annotations

from dataclasses import dataclass
from datetime import timedelta


@dataclass(frozen=True)
class OverdueRules:
    """silent_after: how long the section must have been silent."""

    silent_after: timedelta = timedelta(hours=2)


OVERDUE = OverdueRules()
