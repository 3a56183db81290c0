"""The decision rules of clearance.md, table-driven over every rule and missing/uncertain case."""

from __future__ import annotations

import itertools

import pytest

from service.clearance.rules import (
    ConsistEvidence,
    RunEvidence,
    TailEvidence,
    decide,
    section_state,
)

PRESENT = TailEvidence("present", 0.93)
ABSENT_SURE = TailEvidence("absent", 0.95)
ABSENT_WEAK = TailEvidence("absent", 0.40)
UNCERTAIN = TailEvidence("uncertain", 0.45)
IDENTICAL = ConsistEvidence("identical", "consists identical (12 cars)")
MISSING = ConsistEvidence("missing", "arrival consist lacks cars 0412, 0413 (positions 11–12)")
UNKNOWN = ConsistEvidence("unknown", "positions 3, 7 unreadable")

CASES = [
    # (name, evidence, verdict, a phrase that must be among the reasons)
    (
        "all agree",
        RunEvidence(PRESENT, PRESENT, IDENTICAL, 48, 48),
        "complete",
        "axle counts agree",
    ),
    ("tail only", RunEvidence(arrival_tail=PRESENT), "complete", "tail disc present"),
    ("tail absent sure", RunEvidence(arrival_tail=ABSENT_SURE), "incomplete", "no tail disc"),
    ("tail absent weak", RunEvidence(arrival_tail=ABSENT_WEAK), "undetermined", "low confidence"),
    (
        "tail absent weak, departure present",
        RunEvidence(ABSENT_WEAK, PRESENT),
        "incomplete",
        "seen on departure",
    ),
    ("tail uncertain", RunEvidence(arrival_tail=UNCERTAIN), "undetermined", "uncertain"),
    (
        "tail missing",
        RunEvidence(consist=IDENTICAL, departure_axles=8, arrival_axles=8),
        "undetermined",
        "no arrival image",
    ),
    ("nothing at all", RunEvidence(), "undetermined", "no arrival image"),
    (
        "consist missing cars",
        RunEvidence(PRESENT, consist=MISSING),
        "incomplete",
        "lacks cars 0412, 0413",
    ),
    (
        "consist missing, tail missing",
        RunEvidence(consist=MISSING),
        "incomplete",
        "positions 11–12",
    ),
    ("consist unknown", RunEvidence(PRESENT, consist=UNKNOWN), "undetermined", "unreadable"),
    (
        "fewer axles",
        RunEvidence(PRESENT, departure_axles=48, arrival_axles=40),
        "incomplete",
        "8 missing",
    ),
    (
        "more axles",
        RunEvidence(PRESENT, departure_axles=40, arrival_axles=48),
        "undetermined",
        "disagree",
    ),
    (
        "only departure axles",
        RunEvidence(PRESENT, departure_axles=48),
        "complete",
        "tail disc present",
    ),
    (
        "stale device",
        RunEvidence(PRESENT, stale_devices=("B-cam",)),
        "undetermined",
        "B-cam is silent",
    ),
    (
        "loss beats stale",
        RunEvidence(ABSENT_SURE, stale_devices=("B-ir",)),
        "incomplete",
        "no tail disc",
    ),
    (
        "loss beats uncertain",
        RunEvidence(UNCERTAIN, departure_axles=8, arrival_axles=4),
        "incomplete",
        "4 missing",
    ),
]


@pytest.mark.parametrize(
    ("name", "evidence", "verdict", "phrase"), CASES, ids=[c[0] for c in CASES]
)
def test_rule_table(name: str, evidence: RunEvidence, verdict: str, phrase: str) -> None:
    decision = decide(evidence)
    assert decision.verdict == verdict, (name, decision)
    assert any(phrase in reason for reason in decision.reasons), decision.reasons


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


TAILS = [None, PRESENT, ABSENT_SURE, ABSENT_WEAK, UNCERTAIN]
CONSISTS = [None, IDENTICAL, MISSING, UNKNOWN]
AXLES = [(None, None), (48, 48), (48, 44), (44, 48), (48, None)]


@pytest.mark.parametrize("departure_tail", TAILS)
def test_every_combination_is_safe(departure_tail: TailEvidence | None) -> None:
    """Over all combinations: never "complete" without a present arrival tail, never without
    agreement, and always "incomplete" when an item proves loss."""
    for arrival, consist, (dep, arr), stale in itertools.product(
        TAILS, CONSISTS, AXLES, [(), ("X",)]
    ):
        evidence = RunEvidence(arrival, departure_tail, consist, dep, arr, stale)
        verdict = decide(evidence).verdict
        proves_loss = (
            (arrival is ABSENT_SURE)
            or (arrival in (ABSENT_SURE, ABSENT_WEAK) and departure_tail is PRESENT)
            or consist is MISSING
            or (dep is not None and arr is not None and arr < dep)
        )
        agrees = (
            arrival is PRESENT
            and consist in (None, IDENTICAL)
            and not stale
            and (dep is None or arr is None or dep == arr)
        )
        expected = "incomplete" if proves_loss else "complete" if agrees else "undetermined"
        assert verdict == expected, evidence
