"""Writing wheel marks: every reversal case of §1 as a table, plus simulated physical motion."""

from __future__ import annotations

import numpy as np
import pytest

from identification.simulate import METRO_AXLE_OFFSETS_M, marking_detections
from identification.wheel_marks import simulate_marking

T, F = True, False
THROUGH = ["W1", "W2"]

# (name, detections, state, written, fault substrings)
CASES: list[tuple[str, list[str], str, list[bool], list[str]]] = [
    ("straight through", THROUGH * 4, "marked", [T, T, T, T], []),
    ("straight through from the W2 side", ["W2", "W1"] * 4, "marked", [T, T, T, T], []),
    ("reverses before reaching F: no hits", [], "partial", [F, F, F, F], []),
    ("axle 1 backs out before finishing", ["W1", "W1"], "partial", [F, F, F, F], []),
    (
        "axle 1 backs out, then the car comes again",
        ["W1", "W1", *THROUGH * 4],
        "marked",
        [T, T, T, T],
        [],
    ),
    (
        "axle 3 backs out mid-section, then goes on",
        [*THROUGH * 2, "W1", "W1", *THROUGH * 2],
        "marked",
        [T, T, T, T],
        [],
    ),
    (
        "after axle 2 the car reverses; axle 2 comes back and goes forward out again (duplicate)",
        [*THROUGH * 2, "W2", "W2", *THROUGH * 2],
        "marked",
        [T, T, T, T],
        [],
    ),
    (
        "axle 2 passes backwards through, then forwards again",
        [*THROUGH * 2, "W2", "W1", *THROUGH * 3],
        "marked",
        [T, T, T, T],
        [],
    ),
    (
        "car backs wholly out after two axles: mark lost",
        [*THROUGH * 2, "W2", "W1", "W2", "W1"],
        "lost",
        [F, F, F, F],
        [],
    ),
    (
        "lost, comes again and enters but backs out: still lost",
        [*THROUGH, "W2", "W1", "W1", "W1"],
        "lost",
        [F, F, F, F],
        [],
    ),
    (
        "lost, then marked coming from the other side",
        [*THROUGH, "W2", "W1", *["W2", "W1"] * 4],
        "marked",
        [T, T, T, T],
        [],
    ),
    (
        "marked, then the last axle backs through: marks stay",
        [*THROUGH * 4, "W2", "W1"],
        "marked",
        [T, T, T, T],
        [],
    ),
    ("stops with axle 2 inside", [*THROUGH, "W1"], "partial", [T, F, F, F], ["inside"]),
    (
        "a fifth axle on a four-axle car",
        THROUGH * 5,
        "marked",
        [T, T, T, T],
        ["more axles than the car has"],
    ),
    ("unknown detector", ["W1", "W3", "W2"], "partial", [T, F, F, F], ["unknown detector"]),
    ("backed out of the section only partly written", [*THROUGH * 3], "partial", [T, T, T, F], []),
]


@pytest.mark.parametrize(
    ("detections", "state", "written", "faults"),
    [c[1:] for c in CASES],
    ids=[c[0] for c in CASES],
)
def test_marking_cases(
    detections: list[str], state: str, written: list[bool], faults: list[str]
) -> None:
    r = simulate_marking(detections)
    assert r.state == state
    assert r.written == written
    assert len(r.faults) == len(faults)
    for fault, want in zip(r.faults, faults, strict=True):
        assert want in fault


def test_duplicate_write_is_logged_and_forward_detector_reported() -> None:
    r = simulate_marking([*THROUGH * 2, "W2", "W2", *THROUGH * 2])
    assert r.forward == "W1"
    assert any("axle 2 comes back, writer on with register 2 again" in line for line in r.log)


def test_two_axle_car_and_bad_axles() -> None:
    assert simulate_marking(THROUGH * 2, axles=2).state == "marked"
    with pytest.raises(ValueError, match="axles"):
        simulate_marking(THROUGH, axles=0)


def _random_motion(rng: np.random.Generator, end: str) -> list[float]:
    """Car head positions: a random walk with reversals around the marking station, then a
    final run far past it (``end="past"``) or far back (``end="back"``)."""
    head = -0.5
    path = [head]
    for _ in range(int(rng.integers(20, 200))):
        head += float(rng.uniform(-0.25, 0.35))
        path.append(head)
    target = 25.0 if end == "past" else -1.0
    while abs(head - target) > 0.2:
        head += 0.2 if target > head else -0.2
        path.append(head)
    return path


@pytest.mark.parametrize("end", ["past", "back"])
def test_physical_motion_with_reversals(end: str) -> None:
    rng = np.random.default_rng(5 if end == "past" else 6)
    offsets = np.asarray(METRO_AXLE_OFFSETS_M)
    lost_seen = 0
    for _ in range(300):
        path = _random_motion(rng, end)
        r = simulate_marking(marking_detections(path))
        assert r.faults == []  # no physical motion produces a fault
        if end == "past":
            assert r.state == "marked" and all(r.written)
        else:
            assert not any(r.written)
            some_axle_passed = bool(np.max(np.asarray(path)) - offsets.min() >= 1.0)
            assert r.state == ("lost" if some_axle_passed else "partial")
            lost_seen += r.state == "lost"
    if end == "back":
        assert lost_seen > 30  # the walk did write axles before backing out


def test_marking_detections_geometry() -> None:
    # a car running straight through: each axle hits W1 then W2
    assert marking_detections([-1.0, 30.0]) == THROUGH * 4
    assert marking_detections([30.0, -1.0]) == ["W2", "W1"] * 4
