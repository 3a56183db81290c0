"""The reading-section state machine: latches, oscillation, direction blocking, order check."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from identification.simulate import reading_edges, wheel_mark_passage
from identification.wheel_marks import ReadingSection, decode_passage

BASE = [("DS", c) for c in (2050, 2049, 2051, 2050, 2048, 2050)]


def _run(edges: list[Any]) -> list[Any]:
    return ReadingSection().feed([*BASE, *edges])


# (name, edges after the baseline, expected wheel codes read in order, complete, fault substrings)
CASES: list[tuple[str, list[Any], list[int], bool, list[str]]] = [
    (
        "straight pass, direction 1",
        ["DZ1", ("DOM1-1", 1), ("DOM2-1", 2), ("DOM3-1", 3), ("DOM4-1", 4), "DZ2"],
        [1, 2, 3, 4],
        True,
        [],
    ),
    (
        "oscillation over wheel 2 never re-reads it",
        ["DZ1", ("DOM1-1", 1), ("DOM2-1", 2), ("DOM2-1", 99), ("DOM1-1", 98), ("DOM2-1", 97)]
        + [("DOM3-1", 3), ("DOM4-1", 4), "DZ2"],
        [1, 2, 3, 4],
        True,
        [],
    ),
    (
        "the other direction's sensors are blocked",
        ["DZ2", ("DOM1-1", 9), ("DOM1-2", 1), ("DOM2-1", 9), ("DOM2-2", 2)]
        + [("DOM3-2", 3), ("DOM4-2", 4), "DZ1"],
        [1, 2, 3, 4],
        True,
        [],
    ),
    (
        "out of order strobe is ignored and reported",
        ["DZ1", ("DOM1-1", 1), ("DOM3-1", 3), ("DOM2-1", 2), ("DOM3-1", 33), ("DOM4-1", 4), "DZ2"],
        [1, 2, 33, 4],
        True,
        ["DOM 3-1 before DOM 2-1"],
    ),
    (
        "car reverses after two wheels and backs out through its entry",
        ["DZ1", ("DOM1-1", 1), ("DOM2-1", 2), ("DOM1-1", 5), "DZ1"],
        [1, 2],
        False,
        ["only 2 of 4 wheels read"],
    ),
    (
        "no such sensor",
        ["DZ1", ("DOM5-1", 5), ("DOM1-1", 1), ("DOM2-1", 2), ("DOM3-1", 3), ("DOM4-1", 4), "DZ2"],
        [1, 2, 3, 4],
        True,
        ["no such sensor"],
    ),
]


@pytest.mark.parametrize(
    ("edges", "codes", "complete", "faults"), [c[1:] for c in CASES], ids=[c[0] for c in CASES]
)
def test_reading_cases(
    edges: list[Any], codes: list[int], complete: bool, faults: list[str]
) -> None:
    (reading,) = _run(edges)
    assert [a[0] for a in reading.axles] == codes
    assert reading.complete is complete
    assert len(reading.faults) == len(faults)
    for fault, want in zip(reading.faults, faults, strict=True):
        assert want in fault


def test_direction_baseline_and_latches() -> None:
    rs = ReadingSection(baseline_length=5)
    for _, c in BASE:
        rs.sample(c)
    assert rs.state == "waiting"
    assert rs.edge("DZ2") is None
    assert rs.state == "reading" and rs.direction == 2
    rs.sample(4000)  # a sample during the car does not disturb the frozen zero
    rs.edge("DOM 1-2")  # no value: reads the latest DS sample
    for k in (1, 1, 1):
        rs.edge(f"DOM{k}-2", 0)
    reading = rs.edge("DZ1")
    assert reading is not None
    assert reading.direction == 2
    assert reading.baseline == [2049, 2051, 2050, 2048, 2050]  # the last five before entry
    assert reading.axles == [[4000]]
    assert reading.ignored_strobes == 3
    assert rs.state == "waiting"


def test_short_baseline_is_a_fault_and_sensors_before_a_car_are_ignored() -> None:
    rs = ReadingSection()
    rs.edge("DOM1-1", 5)  # no car yet: nothing happens
    rs.sample(2050)
    rs.edge("DZ1")
    reading = rs.edge("DZ2")
    assert reading is not None and reading.axles == []
    assert any("only 1 baseline samples" in f for f in reading.faults)


def test_bad_sensor_names_raise() -> None:
    rs = ReadingSection()
    with pytest.raises(ValueError, match="unknown sensor"):
        rs.edge("DOM-9")
    with pytest.raises(ValueError, match="DS edge"):
        rs.edge("DS", [1, 2])
    with pytest.raises(ValueError, match="baseline_length"):
        ReadingSection(baseline_length=4)


def test_simulated_passages_with_oscillation_round_trip_to_the_decoder() -> None:
    rng = np.random.default_rng(21)
    for n in range(200):
        code = int(rng.integers(0, 256))
        direction = 1 + n % 2
        passage = wheel_mark_passage(code, direction=direction, rng=rng)
        rs = ReadingSection(baseline_length=len(passage["baseline"]))
        (reading,) = rs.feed(reading_edges(passage, rng=rng, oscillations=3))
        assert reading.complete and reading.faults == []
        assert reading.as_event() == passage
        event = reading.as_event()
        r = decode_passage(event["baseline"], event["axles"], direction=event["direction"])
        assert r.code == code


def test_two_cars_in_a_row() -> None:
    rs = ReadingSection()
    one = ["DZ1", *[(f"DOM{k}-1", k) for k in range(1, 5)], "DZ2"]
    readings = rs.feed([*BASE, *one, *BASE, *one])
    assert len(readings) == 2
    assert all(r.complete for r in readings)
