"""The decision rules of clearance.md, table-driven over every rule and missing/uncertain case."""

from __future__ import annotations

import itertools
from datetime import UTC, datetime, timedelta
from typing import get_args

import pytest

from service.clearance.rules import (
    ConsistEvidence,
    EotEvidence,
    EotReading,
    PassageSilence,
    RunEvidence,
    TailEvidence,
    Verdict,
    ZeroCount,
    decide,
    next_state,
    sweep_clears_original,
)

PRESENT = TailEvidence("present", 0.93)
ABSENT_SURE = TailEvidence("absent", 0.95)
ABSENT_WEAK = TailEvidence("absent", 0.40)
UNCERTAIN = TailEvidence("uncertain", 0.45)
IDENTICAL = ConsistEvidence("identical", "consists identical (12 cars)")
MISSING = ConsistEvidence("missing", "arrival consist lacks cars 0412, 0413 (positions 11–12)")
UNKNOWN = ConsistEvidence("unknown", "positions 3, 7 unreadable")
UNIT = 39572
HEARD = datetime(2026, 11, 23, 10, 2, tzinfo=UTC)


def silent(device: str) -> PassageSilence:
    """``device`` not heard from 10:02Z on, while the train passed."""
    return PassageSilence(device, HEARD, HEARD + timedelta(minutes=9))


def eot(*pressures: int, unit: int | None = UNIT, other: int | None = None) -> EotEvidence:
    """The train's unit ``unit`` reporting ``pressures`` in order, plus one report of ``other``."""
    reports = [EotReading(UNIT, p) for p in pressures]
    if other is not None:
        reports.insert(0, EotReading(other, 88))
    return EotEvidence(unit=unit, reports=tuple(reports))


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
        RunEvidence(PRESENT, silences=(silent("B-cam"),)),
        "undetermined",
        "B-cam is silent",
    ),
    (
        "silence is dated",
        RunEvidence(PRESENT, silences=(silent("B-wm"),)),
        "undetermined",
        "B-wm is silent past its heartbeat deadline while the train passed (nothing received"
        " from 2026-11-23T10:02:00Z)",
    ),
    (
        "zero axles counted on both sides are no agreement",
        RunEvidence(
            PRESENT,
            zero_counts=(ZeroCount("A-ac", "A"), ZeroCount("B-ac", "B")),
        ),
        "undetermined",
        "the axle counter A-ac at A reported 0 axles for a train: that is no count",
    ),
    (
        "a live reader that said nothing is named, the verdict unchanged",
        RunEvidence(PRESENT, consist=IDENTICAL, unheard=("B-wm",)),
        "complete",
        "device B-wm is alive but reported nothing for this train",
    ),
    (
        "loss beats stale",
        RunEvidence(ABSENT_SURE, silences=(silent("B-ir"),)),
        "incomplete",
        "no tail disc",
    ),
    (
        "loss beats uncertain",
        RunEvidence(UNCERTAIN, departure_axles=8, arrival_axles=4),
        "incomplete",
        "4 missing",
    ),
    # End-of-train telemetry (clearance.md, "End-of-train telemetry").
    (
        "EOT at pressure stands in for a missing tail image",
        RunEvidence(eot=eot(89)),
        "complete",
        "EOT unit 39572 at the rear reports 89 psig at arrival",
    ),
    (
        "EOT at exactly 45 psig stands in",
        RunEvidence(eot=eot(45), consist=IDENTICAL),
        "complete",
        "45 psig",
    ),
    (
        "EOT stands in for an uncertain tail",
        RunEvidence(UNCERTAIN, eot=eot(70)),
        "complete",
        "the EOT unit stands in",
    ),
    ("EOT 44 psig is not enough", RunEvidence(eot=eot(44)), "undetermined", "only 44 psig"),
    (
        "EOT 44 psig doubts even a present tail",
        RunEvidence(PRESENT, eot=eot(44)),
        "undetermined",
        "only 44 psig",
    ),
    (
        "EOT vented proves loss",
        RunEvidence(PRESENT, eot=eot(4)),
        "incomplete",
        "brake pipe vented at the rear: the train may have parted",
    ),
    ("EOT vented at 0", RunEvidence(eot=eot(90, 0)), "incomplete", "reports 0 psig"),
    ("EOT 5 psig is not a vent", RunEvidence(eot=eot(5)), "undetermined", "only 5 psig"),
    (
        "the last report counts: recharged after a dip",
        RunEvidence(eot=eot(2, 80)),
        "complete",
        "80 psig",
    ),
    (
        "another unit is ignored with a reason",
        RunEvidence(eot=eot(unit=UNIT, other=10690)),
        "undetermined",
        "EOT unit 10690 is not this train's unit (39572): its report is ignored",
    ),
    (
        "another unit cannot stand in",
        RunEvidence(eot=eot(unit=UNIT, other=10690)),
        "undetermined",
        "no report from EOT unit 39572 at arrival",
    ),
    (
        "another unit's vent proves nothing",
        RunEvidence(PRESENT, eot=EotEvidence(UNIT, (EotReading(10690, 0),))),
        "complete",
        "is ignored",
    ),
    (
        "no unit armed: every report ignored",
        RunEvidence(eot=eot(unit=None, other=10690)),
        "undetermined",
        "no EOT unit was armed on this train: ignored",
    ),
    (
        "EOT missing leaves the tail to decide",
        RunEvidence(PRESENT, eot=eot()),
        "complete",
        "tail disc present",
    ),
    (
        "EOT cannot outvote a missing car",
        RunEvidence(consist=MISSING, eot=eot(89)),
        "incomplete",
        "lacks cars",
    ),
    (
        "EOT does not overrule a weak absent tail",
        RunEvidence(ABSENT_WEAK, eot=eot(89)),
        "undetermined",
        "low confidence",
    ),
    (
        "EOT does not overrule a stale device",
        RunEvidence(silences=(silent("B-eot"),), eot=eot(89)),
        "undetermined",
        "B-eot is silent",
    ),
]


@pytest.mark.parametrize(
    ("name", "evidence", "verdict", "phrase"), CASES, ids=[c[0] for c in CASES]
)
def test_rule_table(name: str, evidence: RunEvidence, verdict: str, phrase: str) -> None:
    decision = decide(evidence)
    assert decision.verdict == verdict, (name, decision)
    assert any(phrase in reason for reason in decision.reasons), decision.reasons


TAILS = [None, PRESENT, ABSENT_SURE, ABSENT_WEAK, UNCERTAIN]
CONSISTS = [None, IDENTICAL, MISSING, UNKNOWN]
AXLES = [(None, None), (48, 48), (48, 44), (44, 48), (48, None)]


@pytest.mark.parametrize("departure_tail", TAILS)
def test_every_combination_is_safe(departure_tail: TailEvidence | None) -> None:
    """Over all combinations: never "complete" without a present arrival tail, never without
    agreement, and always "incomplete" when an item proves loss."""
    for arrival, consist, (dep, arr), stale, zeros in itertools.product(
        TAILS, CONSISTS, AXLES, [(), (silent("X"),)], [(), (ZeroCount("X-ac", "X"),)]
    ):
        evidence = RunEvidence(arrival, departure_tail, consist, dep, arr, stale, zero_counts=zeros)
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
            and not zeros  # a counter that counted 0 axles counted nothing
            and (dep is None or arr is None or dep == arr)
            # rule 2: a departure image without the disc contradicts the arrival's disc
            and departure_tail not in (ABSENT_SURE, ABSENT_WEAK)
        )
        expected = "incomplete" if proves_loss else "complete" if agrees else "undetermined"
        assert verdict == expected, evidence


EOTS = [
    None,
    eot(),
    eot(89),
    eot(45),
    eot(44),
    eot(5),
    eot(4),
    eot(89, 0),
    eot(0, 89),
    eot(unit=UNIT, other=10690),
    eot(unit=None, other=10690),
]


@pytest.mark.parametrize("eot_evidence", EOTS)
def test_every_combination_with_eot_is_safe(eot_evidence: EotEvidence | None) -> None:
    """With EOT in the evidence: "complete" needs the tail present or the own unit's last
    report ≥ 45 psig; the own unit's last report < 5 psig always proves loss; other units'
    reports never change the verdict."""
    own = (
        []
        if eot_evidence is None
        else [r for r in eot_evidence.reports if r.unit_address == eot_evidence.unit]
    )
    last = own[-1].pressure_psig if own else None
    for arrival, departure, consist, (dep, arr), stale in itertools.product(
        TAILS, TAILS, CONSISTS, AXLES, [(), (silent("X"),)]
    ):
        evidence = RunEvidence(arrival, departure, consist, dep, arr, stale, eot_evidence)
        verdict = decide(evidence).verdict
        proves_loss = (
            (arrival is ABSENT_SURE)
            or (arrival in (ABSENT_SURE, ABSENT_WEAK) and departure is PRESENT)
            or consist is MISSING
            or (dep is not None and arr is not None and arr < dep)
            or (last is not None and last < 5)
        )
        whole = arrival is PRESENT or (
            last is not None and last >= 45 and arrival in (None, UNCERTAIN)
        )
        agrees = (
            whole
            and consist in (None, IDENTICAL)
            and not stale
            and (dep is None or arr is None or dep == arr)
            and (last is None or last >= 45)
            and not (arrival is PRESENT and departure in (ABSENT_SURE, ABSENT_WEAK))
        )
        expected = "incomplete" if proves_loss else "complete" if agrees else "undetermined"
        assert verdict == expected, evidence


@pytest.mark.parametrize("mode", ["primary", "auxiliary"])
def test_a_sweep_run_that_is_not_complete_never_frees_the_section(mode: str) -> None:
    """Exhaustive over every evidence combination (with and without EOT) and every sequence of
    up to three re-decisions of the sweep run: the section reaches ``free`` only by a decision
    ``complete``, and the original run counts as cleared only when the sweep is complete."""
    verdicts: set[str] = set()
    for arrival, departure, consist, (dep, arr), stale, eot_evidence in itertools.product(
        TAILS, TAILS, CONSISTS, AXLES, [(), (silent("X"),)], EOTS
    ):
        evidence = RunEvidence(arrival, departure, consist, dep, arr, stale, eot_evidence)
        verdict = decide(evidence).verdict
        verdicts.add(verdict)
        after = next_state("occupied", verdict, mode)  # the sweep run held the section
        assert (after == "free") == (verdict == "complete" and mode == "primary"), evidence
        assert sweep_clears_original(verdict) == (verdict == "complete")
    assert verdicts == set(get_args(Verdict))
    for sequence in itertools.product(get_args(Verdict), repeat=3):
        state = "occupied"
        for step in sequence:
            before = state
            state = next_state(state, step, mode)
            if state == "free" and before != "free":
                assert step == "complete", sequence
