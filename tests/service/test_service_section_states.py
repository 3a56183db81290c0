"""The section states of clearance.md: what each run verdict makes of a section, by mode and
by the state it was in, and the sweep train's rules."""

from __future__ import annotations

from typing import get_args

import pytest

from service.clearance.rules import (
    SECTION_STATE,
    SWEEP_FROM,
    Verdict,
    departure_opens_sweep,
    next_state,
    section_state,
    sweep_clears_original,
)


@pytest.mark.parametrize(
    ("verdict", "mode", "state"),
    [
        ("complete", "primary", "free"),
        ("complete", "auxiliary", "awaiting_confirmation"),
        ("undetermined", "primary", "review"),
        ("undetermined", "auxiliary", "review"),
        ("incomplete", "primary", "alarm"),
        ("incomplete", "auxiliary", "alarm"),
    ],
)
def test_section_state_by_mode(verdict: str, mode: str, state: str) -> None:
    assert section_state(verdict, mode) == state  # type: ignore[arg-type]


STATES = ["free", "occupied", "awaiting_confirmation", "review", "alarm", "blocked",
          "awaiting_sweep"]  # fmt: skip
VERDICTS: list[Verdict] = list(get_args(Verdict))


@pytest.mark.parametrize(
    ("current", "verdict", "mode", "state"),
    [
        # a sweep run holds the section as "occupied" and follows the normal table
        ("occupied", "complete", "primary", "free"),
        ("occupied", "complete", "auxiliary", "awaiting_confirmation"),
        ("occupied", "incomplete", "primary", "alarm"),
        ("occupied", "undetermined", "primary", "review"),
        ("occupied", "undetermined", "auxiliary", "review"),
        # awaiting a sweep: only proof of loss moves it (to alarm); doubt or proof do not free it
        ("awaiting_sweep", "complete", "primary", "awaiting_sweep"),
        ("awaiting_sweep", "undetermined", "primary", "awaiting_sweep"),
        ("awaiting_sweep", "incomplete", "primary", "alarm"),
        ("blocked", "incomplete", "primary", "blocked"),
        ("alarm", "complete", "primary", "alarm"),
    ],
)
def test_next_state_table(current: str, verdict: str, mode: str, state: str) -> None:
    assert next_state(current, verdict, mode) == state  # type: ignore[arg-type]


def test_sweep_is_asked_only_where_nothing_proves_the_section_empty() -> None:
    assert {"alarm", "review", "blocked"} == SWEEP_FROM
    assert {s for s in STATES if departure_opens_sweep(s)} == {"awaiting_sweep"}
    assert [v for v in VERDICTS if sweep_clears_original(v)] == ["complete"]
    assert not sweep_clears_original(None)


def test_awaiting_sweep_is_never_freed_by_the_swept_run_itself() -> None:
    """Late evidence re-deciding the original run, whatever it says, never frees a section
    that awaits its sweep train (only the sweep run or a dispatcher's clear can)."""
    for verdict, mode in SECTION_STATE:
        assert next_state("awaiting_sweep", verdict, mode) in ("awaiting_sweep", "alarm")  # type: ignore[arg-type]
