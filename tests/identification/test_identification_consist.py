"""Consists: majority of IR reads, assembly through the registry, comparison, axle sums."""

from __future__ import annotations

import pytest

from identification.consist import (
    CarRead,
    assemble_consist,
    axle_sum,
    combine_reads,
    compare_axles,
    compare_consists,
    identify_car,
    majority_number,
)


@pytest.mark.parametrize(
    ("reads", "number"),
    [
        ([117, 117, 119, 117, 117], 117),  # protocol.md ir_id example
        ([5], 5),
        ([5, 6], None),
        ([5, 5, 6, 6], None),
        ([5, 5, 6], 5),
        ([], None),
    ],
)
def test_majority_number(reads: list[int], number: int | None) -> None:
    assert majority_number(reads) == number


WHEEL = {117: "0117", 118: "0118", 412: "0412"}
IR = {117: "0117", 118: "0118", 500: "0500"}  # 0412 has no IR number, 0500 no wheel code


@pytest.mark.parametrize(
    ("read", "car", "status"),
    [
        (CarRead(117, 117), "0117", "identified"),
        (CarRead(117, None), "0117", "identified"),
        (CarRead(None, 118), "0118", "identified"),
        (CarRead(117, 118), None, "conflict"),
        (CarRead(412, 999), "0412", "identified"),  # 0412 has no IR number registered
        (CarRead(999, 117), None, "conflict"),  # 0117's wheel code is 117, not 999
        (CarRead(999, 500), "0500", "identified"),  # 0500 has no wheel code registered
        (CarRead(999, None), None, "unregistered"),
        (CarRead(None, None), None, "unread"),
    ],
)
def test_identify_car(read: CarRead, car: str | None, status: str) -> None:
    e = identify_car(read, wheel_codes=WHEEL, ir_numbers=IR)
    assert (e.car, e.status) == (car, status)
    assert (e.wheel_code, e.ir_number) == (read.wheel_code, read.ir_number)  # raw reads kept


def test_assemble_consist_keeps_unknown_reads_and_reports_conflicts() -> None:
    reads, notes = combine_reads([117, 999, 117, None], [117, None, 118])
    assert notes == ["wheel-mark reader saw 4 cars, infrared reader 3"]
    c = assemble_consist(reads, wheel_codes=WHEEL, ir_numbers=IR, direction=1)
    assert c.car_ids == ["0117", None, None, None]
    assert [e.status for e in c.entries] == ["identified", "unregistered", "conflict", "unread"]
    assert [e.position for e in c.entries] == [1, 2, 3, 4]
    assert c.entries[1].wheel_code == 999
    assert c.notes == ["position 3: wheel marks say 0117, infrared says 0118"]
    assert len(c.conflicts) == 1


# (departure, arrival, status, missing, unknown positions, reason substring)
CASES = [
    (["a", "b", "c"], ["a", "b", "c"], "identical", [], [], "identical to departure (3 cars)"),
    (
        [f"04{k:02d}" for k in range(3, 14)] + [],
        [f"04{k:02d}" for k in range(3, 12)],
        "missing",
        [(10, "0412"), (11, "0413")],
        [],
        "arrival consist lacks cars 0412, 0413 (positions 10–11)",
    ),
    (["a", "b", "c"], ["a", None, "c"], "unknown", [], [2], "position 2 not identified"),
    (["a", None, "c"], ["a", "b", "c"], "unknown", [], [2], "position 2 not identified"),
    (
        ["a", "b", "c", "d"],
        ["a", None, "c"],
        "missing",
        [(4, "d")],
        [2],
        "lacks car d (position 4); 3 cars arrived of 4 departed, 1 of them unidentified",
    ),
    (["a", "b", "c"], ["a", "x", "c"], "missing", [(2, "b")], [], "extra car x (position 2)"),
    (["a", "b"], ["b", "a"], "unknown", [], [2], "out of the departure order"),
    (["a", "b", "c"], [None, "a", "c"], "unknown", [], [2], "1 arrival car(s) are unidentified"),
    (["a", "b"], ["a", "b", "z"], "unknown", [], [], "extra car z (position 3)"),
    (["a", "b"], [], "unknown", [], [1, 2], "no arrival consist"),
    ([], ["a"], "unknown", [], [], "no departure consist"),
    (["a", "b", "c"], ["a", "c"], "missing", [(2, "b")], [], "lacks car b (position 2)"),
    ([None, "b"], ["b"], "missing", [(1, None)], [], "lacks car (unidentified) (position 1)"),
]


@pytest.mark.parametrize(("dep", "arr", "status", "missing", "unknown", "reason"), CASES)
def test_compare_consists(
    dep: list[str | None],
    arr: list[str | None],
    status: str,
    missing: list[tuple[int, str]],
    unknown: list[int],
    reason: str,
) -> None:
    r = compare_consists(dep, arr)
    assert r.status == status
    assert r.missing == missing
    assert r.unknown_positions == unknown
    assert reason in r.reason
    assert (r.status == "missing") == bool(r.missing)


def test_aligned_rows_for_display() -> None:
    r = compare_consists(["0401", "0402", "0403", "0404"], ["0401", None, "0403"])
    assert r.aligned == [
        ("0401", "0401", "same"),
        ("0402", None, "unknown"),
        ("0403", "0403", "same"),
        ("0404", None, "missing"),
    ]
    r = compare_consists(["a", "b"], ["a", "b", "z"])
    assert r.aligned[-1] == (None, "z", "extra") and r.extra == [(3, "z")]


def test_lost_rear_part_with_the_clearance_wording() -> None:
    dep = [f"04{k:02d}" for k in range(3, 14)]  # positions 1…11: 0403 … 0413
    arr = dep[:9]
    r = compare_consists(["0400", *dep], ["0400", *arr])
    assert r.reason == "arrival consist lacks cars 0412, 0413 (positions 11–12)"


def test_axle_sum_and_compare_axles() -> None:
    axles = {"0117": 4, "0118": 4, "loco": 6}
    assert axle_sum(["0117", "0118", "loco"], axles) == 14
    assert axle_sum(["0117", None], axles) is None
    assert axle_sum(["0117", None, "ghost"], axles, default_axles=4) == 12
    assert axle_sum([], axles) == 0
    assert compare_axles(212, 212).status == "equal"
    fewer = compare_axles(212, 204)
    assert (fewer.status, fewer.difference) == ("fewer", -8)
    assert "8 missing" in fewer.reason
    assert compare_axles(212, 216).status == "more"
    assert compare_axles(None, 216).status == "unknown"


def test_an_unidentified_position_says_which_side_lacked_the_identification() -> None:
    """An independent trial: "departure position 2 not identified on both sides" read as
    "on neither side" or "on one of them". The reason names the side that lacked it."""
    departure_only = compare_consists(["a", None, "c"], ["a", "b", "c"])
    assert (
        "departure position 2 not identified at departure (arrival: car b)" in departure_only.reason
    )
    arrival_only = compare_consists(["a", "b", "c"], ["a", None, "c"])
    assert (
        "departure position 2 not identified on arrival (departure: car b)" in arrival_only.reason
    )
    neither = compare_consists(["a", None, "c"], ["a", None, "c"])
    assert "departure position 2 identified on neither side" in neither.reason
    for r in (departure_only, arrival_only, neither):
        assert "both sides" not in r.reason, r.reason
        assert r.status == "unknown" and r.unknown_positions == [2]
