"""Liveness over the passage (trial F4, F3, G2): a device that sent nothing for a train is
judged silent at any time the train may have passed it, not at one instant; a count of 0
axles is no count; a live reader that reported nothing is named. And a decision reads
liveness only from the events stored before the one it derives from, so ``depot replay``
gives the decision shown live even when a receive time is older than its row.

Each event reaches the server at its device time (the server's clock is the test's); the
heartbeat period is 60 s and the line's devices heartbeat each 55 s while alive
(``Line.keep_alive``).
"""

from __future__ import annotations

from datetime import datetime, timedelta
from typing import Any

import pytest
from fastapi.testclient import TestClient
from sqlalchemy.orm import Session

from service.replay import replay
from tests.conftest import ADMIN
from tests.service.clock import ServerClock, server_clock  # noqa: F401 (fixture)
from tests.service.scenario import T0, Line, jpeg

ARRIVE = T0 + timedelta(minutes=20)
SECOND = timedelta(seconds=1)
CARS = [117, 118, 119, 120]


@pytest.fixture
def line(client: TestClient, server_clock: ServerClock) -> Line:  # noqa: F811
    return Line.clocked(client, server_clock)


def journey(
    line: Line,
    *,
    quiet: tuple[str, ...] = (),
    heard: dict[str, list[datetime]] | None = None,
    arrival_reads: bool = True,
) -> dict[str, Any]:
    """Train 2041 (cars 117–120) from A to B: every device but ``quiet`` heartbeats
    (``Line.keep_alive``) from 10 min before the departure to the arrival; ``heard`` gives
    quiet devices their own heartbeats. Both IR readers read the cars (B's only with
    ``arrival_reads``), the tail disc is seen on arrival. Returns the arrival's answer."""
    own = sorted((at, device) for device, times in (heard or {}).items() for at in times)
    for at, device in own:
        if at < T0:
            line.post(device, "heartbeat", at)
    line.keep_alive(T0 - 10 * 60 * SECOND, T0 - 20 * SECOND, except_=quiet)
    line.read("A", CARS, T0 - 30 * SECOND)
    line.depart()
    line.keep_alive(T0 + 10 * SECOND, ARRIVE - 30 * SECOND, except_=quiet)
    for at, device in own:
        if at >= T0:
            line.post(device, "heartbeat", at)
    if arrival_reads:
        line.read("B", CARS, ARRIVE - 60 * SECOND)
    line.snapshot("B-cam", ARRIVE - 5 * SECOND, jpeg(disc=True, seed=21))
    return line.arrive(ARRIVE)


def silent_reasons(reasons: list[str]) -> list[str]:
    return [r for r in reasons if "is silent" in r]


def test_everyone_heard_throughout_frees_the_section(line: Line) -> None:
    """The baseline the other tests break one way each."""
    result = journey(line)
    assert result["verdict"] == "complete", result
    assert line.section()["state"] == "free"


def test_a_reader_silent_while_the_train_passed_but_alive_at_arrival_is_a_doubt(
    line: Line,
) -> None:
    """F4: B's wheel-mark reader was heard at the departure and again 30 s before the
    arrival, and not between: the train passed it meanwhile, and it said nothing. Judged at
    the arrival's instant alone it looked alive, and its missing consist looked like nothing
    to report."""
    heard = {"B-wm": [T0 - 20 * SECOND, ARRIVE - 30 * SECOND]}
    result = journey(line, quiet=("B-wm",), heard=heard)
    assert result["verdict"] == "undetermined", result
    named = silent_reasons(result["reasons"])
    assert [r.split()[1] for r in named] == ["B-wm"], result["reasons"]
    assert "from 2026-11-23T09:59:40Z to 2026-11-23T10:19:30Z" in named[0], named
    assert line.section()["state"] == "review"
    evidence = line.section()["run"]["evidence"]
    assert [s["device"] for s in evidence["silent_while_passing"]] == ["B-wm"], evidence


def test_a_departure_reader_silent_before_the_departure_is_a_doubt(line: Line) -> None:
    """F4, the other end: A's wheel-mark reader was heard 15 min and 20 s before the departure,
    not between: it may have been silent while the train left, though alive at the departure's
    instant."""
    heard = {"A-wm": [T0 - 15 * 60 * SECOND, T0 - 20 * SECOND, T0 + 30 * SECOND]}
    result = journey(line, quiet=("A-wm",), heard=heard)
    assert result["verdict"] == "undetermined", result
    assert [r.split()[1] for r in silent_reasons(result["reasons"])] == ["A-wm"], result
    assert line.section()["state"] == "review"


@pytest.mark.parametrize(("every_s", "silent"), [(55, False), (70, True)])
def test_a_gap_counts_only_past_the_heartbeat_period(
    line: Line, every_s: int, silent: bool
) -> None:
    """B-wm heartbeats every 55 s (within the 60 s period: alive) or every 70 s (a silence)."""
    start = T0 - 10 * 60 * SECOND
    times = [start + k * every_s * SECOND for k in range(31 * 60 // every_s)]
    result = journey(line, quiet=("B-wm",), heard={"B-wm": times})
    assert (result["verdict"] == "undetermined") is silent, result
    assert bool(silent_reasons(result["reasons"])) is silent, result


@pytest.mark.parametrize(
    ("departed", "arrived"),
    [(0, 0), (16, 0), (0, 16)],
    ids=["both 0", "arrival 0", "departure 0"],
)
def test_an_axle_count_of_zero_is_no_count(line: Line, departed: int, arrived: int) -> None:
    """F3: a counter that reports 0 axles for a train counted nothing. Two zeros are not
    "axle counts agree", and a zero on one side is no proof of 16 lost axles: a person must
    look (review, not free and not alarm)."""
    line.post("A-ac", "axle_count", T0 - 10 * SECOND, section="AB", axles=departed)
    line.post("B-ac", "axle_count", ARRIVE - 20 * SECOND, section="AB", axles=arrived)
    result = journey(line)
    assert result["verdict"] == "undetermined", result
    zero = [r for r in result["reasons"] if "reported 0 axles" in r]
    assert len(zero) == (2 if departed == arrived == 0 else 1), result["reasons"]
    assert not any("axle counts agree" in r or "missing)" in r for r in result["reasons"])
    assert line.section()["state"] == "review"


@pytest.mark.parametrize("reads", [False, True], ids=["said nothing", "read the cars"])
def test_a_live_reader_that_said_nothing_is_named(line: Line, reads: bool) -> None:
    """G2: B's IR reader heartbeat throughout but read none of the train's cars: nothing is
    compared, the tail disc decides; the reasons say that the reader's evidence is missing
    (so are the wheel-mark reader's and the axle counter's, which say nothing on this line)."""
    result = journey(line, arrival_reads=reads)
    assert result["verdict"] == "complete", result
    named = [r.split()[1] for r in result["reasons"] if "alive but reported nothing" in r]
    assert named == (["B-ac", "B-wm"] if reads else ["B-ac", "B-ir", "B-wm"]), result["reasons"]


def test_replay_reads_liveness_as_the_decision_did(
    line: Line,
    session: Session,
    server_clock: ServerClock,  # noqa: F811
) -> None:
    """B-wm is silent at the arrival (heard 20 min before); a heartbeat whose receive time is
    10 s before the arrival is stored only after the arrival was decided (a broker's time, a
    bridge's backlog). Live the run was decided without it; ``depot replay`` must decide the
    same, not read a row that was not there yet."""
    result = journey(line, quiet=("B-wm",), heard={"B-wm": [T0 - 20 * SECOND]})
    assert result["verdict"] == "undetermined", result
    line.post("B-wm", "heartbeat", ARRIVE + SECOND, received=ARRIVE - 10 * SECOND)
    before = line.section()["run"]
    replay(session)
    session.commit()
    after = line.section()["run"]
    assert after["decision"] == before["decision"], (before["decision"], after["decision"])
    assert after["evidence"] == before["evidence"]


@pytest.mark.parametrize("silent", [False, True], ids=["all heard", "B-wm silent"])
def test_a_departure_received_after_the_arrival_still_judges_the_arrival_end(
    line: Line, silent: bool
) -> None:
    """A's interlocking link was down: its departure reaches the server 30 s after B's arrival
    (the arrival waits for it, then the departure closes the run). The train passed B in the
    10 min before the arrival was received, whatever the departure's receipt says."""
    quiet = ("B-wm",) if silent else ()
    line.keep_alive(T0 - 10 * 60 * SECOND, T0 - 20 * SECOND)
    line.read("A", CARS, T0 - 30 * SECOND)
    line.keep_alive(T0 + 10 * SECOND, ARRIVE - 30 * SECOND, except_=quiet)
    if silent:
        line.post("B-wm", "heartbeat", ARRIVE - 30 * SECOND)  # alive at the arrival's instant
    line.read("B", CARS, ARRIVE - 60 * SECOND)
    line.snapshot("B-cam", ARRIVE - 5 * SECOND, jpeg(disc=True, seed=21))
    line.arrive(ARRIVE)
    departed = line.post("A-ilk", "train_departed", T0, received=ARRIVE + 30 * SECOND,
                         section="AB", train="2041")  # fmt: skip
    run = line.client.get(f"/api/v1/runs/{departed['run']}", headers=ADMIN).json()
    assert run["decision"]["verdict"] == ("undetermined" if silent else "complete"), run
    named = [r.split()[1] for r in silent_reasons(run["decision"]["reasons"])]
    assert named == (["B-wm"] if silent else []), run["decision"]["reasons"]
