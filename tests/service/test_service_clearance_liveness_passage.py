"""Devices at the arrival end must have been alive while the train passed them, and their
counts must be counts (an independent trial, F4, F3, G2).

F4: a wheel-mark reader at B, silent for nine minutes while the train ran in and passed it,
sent a heartbeat 30 s before the arrival: alive at the arrival's moment, its missing consist
was no doubt, and the section was freed. F3: axle counters that report 0 axles (broken or
unpowered) "agreed" with each other, and a 0 at the arrival "proved" a loss. G2: a live reader
that reported nothing for a train was not mentioned at all.

Every event reaches the server at its device time (``tests/service/clock``), so that a test
can say how long the server heard nothing from a device.
"""

from __future__ import annotations

from datetime import datetime, timedelta
from typing import Any

import pytest
from fastapi.testclient import TestClient
from sqlalchemy.orm import Session

from service.replay import replay
from tests.service.clock import ServerClock, server_clock  # noqa: F401 (fixture)
from tests.service.conflictkit import run_of
from tests.service.linekit import build_line
from tests.service.scenario import ARRIVAL_END, T0, Line, jpeg

ARRIVE = T0 + timedelta(minutes=20)
SECOND, MINUTE = timedelta(seconds=1), timedelta(minutes=1)
CARS = [117, 118, 119, 120]  # 4 axles each
DEPARTURE_END = ("A-ac", "A-cam", "A-ir", "A-wm")


@pytest.fixture
def clocked(client: TestClient, server_clock: ServerClock) -> Line:  # noqa: F811
    """The line, its devices registered an hour before the first train (a device's silence
    counts only from its registration)."""
    server_clock.set(T0 - timedelta(hours=1))
    return Line(client, build_line(client), clock=server_clock)


def count(line: Line, device: str, axles: int, at: datetime) -> None:
    line.post(device, "axle_count", at, section="AB", axles=axles)


def passage(line: Line, *, wm_silent_from: datetime | None, departed: datetime = T0) -> int:
    """2041 leaves A (4 cars read, 16 axles) and reaches B complete: the same cars read, 16
    axles, the tail disc seen. B's devices send heartbeats from 11 min before the arrival;
    the wheel-mark reader B-wm (which reads nothing of this train) stops at ``wm_silent_from``
    and is heard again 30 s before the arrival. A's devices are heard while the train leaves."""
    line.keep_alive(departed - 11 * MINUTE, departed - 20 * SECOND, DEPARTURE_END)
    line.heartbeat_all(departed - 20 * SECOND)
    line.read("A", CARS, departed - 30 * SECOND)
    run = line.depart(departed)
    count(line, "A-ac", 16, departed + 15 * SECOND)
    quiet = ARRIVE if wm_silent_from is None else wm_silent_from
    at = ARRIVE - 11 * MINUTE
    while at <= ARRIVE - 45 * SECOND:  # every 45 s, within the heartbeat period (60 s)
        line.keep_alive(at, at, tuple(d for d in ARRIVAL_END if d != "B-wm" or at <= quiet))
        at += 45 * SECOND
    line.read("B", CARS, ARRIVE - 40 * SECOND)
    line.post("B-wm", "heartbeat", ARRIVE - 30 * SECOND)
    count(line, "B-ac", 16, ARRIVE - 20 * SECOND)
    line.snapshot("B-cam", ARRIVE - 5 * SECOND, jpeg(disc=True))
    line.arrive(ARRIVE)
    return run


def test_f4_a_reader_silent_while_the_train_passed_is_a_doubt(clocked: Line) -> None:
    run = passage(clocked, wm_silent_from=ARRIVE - 9 * MINUTE)
    shown = run_of(clocked, run)
    decision = shown["decision"]
    assert decision["verdict"] == "undetermined", decision
    assert clocked.section()["state"] == "review"
    # Its last heartbeat before the gap: 11 min before, then every 45 s up to 9 min before.
    named = [r for r in decision["reasons"] if "B-wm" in r]
    assert named == [
        "device B-wm was silent from 2026-11-23T10:10:30Z to 2026-11-23T10:19:30Z while the"
        " train passed; its evidence is missing; a person must look"
    ], decision["reasons"]
    assert shown["evidence"]["silent_while_passing"] == [
        {"device": "B-wm", "from": "2026-11-23T10:10:30Z", "to": "2026-11-23T10:19:30Z"}
    ]


def test_f4_replay_decides_the_silent_reader_the_same(clocked: Line, session: Session) -> None:
    run = passage(clocked, wm_silent_from=ARRIVE - 9 * MINUTE)
    live = run_of(clocked, run)
    replay(session)
    session.commit()
    again = run_of(clocked, run)
    assert again["decision"]["verdict"] == live["decision"]["verdict"] == "undetermined"
    assert again["decision"]["reasons"] == live["decision"]["reasons"]
    assert again["evidence"] == live["evidence"]
    assert clocked.section()["state"] == "review"


def test_f4_a_reader_alive_throughout_frees_the_section(clocked: Line) -> None:
    """The control: nothing but the reader's silence differs. (G2: it is alive and read
    nothing, so the decision says so, and stands.)"""
    run = passage(clocked, wm_silent_from=None)
    decision = run_of(clocked, run)["decision"]
    assert decision["verdict"] == "complete", decision
    assert clocked.section()["state"] == "free"
    assert not any("silent" in r for r in decision["reasons"]), decision["reasons"]


def test_f4_an_outage_long_before_the_arrival_does_not_count(clocked: Line) -> None:
    """The window reaches back 10 min (``PassageTimes.believed_lateness``): a train that left
    three hours ago does not turn every outage since into a doubt."""
    run = passage(clocked, wm_silent_from=None, departed=ARRIVE - timedelta(hours=3))
    decision = run_of(clocked, run)["decision"]
    assert decision["verdict"] == "complete", decision
    assert clocked.section()["state"] == "free"


# --- F3: a count of 0 axles is no count ------------------------------------------------------


def counted(line: Line, departure: int, arrival: int, *, read: bool) -> dict[str, Any]:
    """2041 through AB with its tail disc seen; the counters report these axles; the IR
    readers read the four cars at both ends when ``read``."""
    line.heartbeat_all(T0 - 20 * SECOND)
    if read:
        line.read("A", CARS, T0 - 30 * SECOND)
    run = line.depart(T0)
    count(line, "A-ac", departure, T0 + 15 * SECOND)
    arrive = T0 + 2 * MINUTE
    if read:
        line.read("B", CARS, arrive - 40 * SECOND)
    count(line, "B-ac", arrival, arrive - 20 * SECOND)
    line.snapshot("B-cam", arrive - 5 * SECOND, jpeg(disc=True))
    line.arrive(arrive)
    return run_of(line, run)


def test_f3_two_counts_of_zero_do_not_agree(line: Line) -> None:
    shown = counted(line, 0, 0, read=True)
    decision = shown["decision"]
    assert decision["verdict"] == "undetermined", decision
    assert line.section()["state"] == "review"
    assert not any("agree (0)" in r for r in decision["reasons"]), decision["reasons"]
    for device, station in (("A-ac", "A"), ("B-ac", "B")):
        assert any(
            f"axle counter {device} at {station} reported 0 axles for a train" in r
            for r in decision["reasons"]
        ), decision["reasons"]
    assert shown["evidence"]["zero_axle_counts"] == ["A-ac", "B-ac"]


def test_f3_an_arrival_count_of_zero_proves_no_loss(line: Line) -> None:
    decision = counted(line, 16, 0, read=False)["decision"]
    assert decision["verdict"] == "undetermined", decision
    assert line.section()["state"] == "review"
    assert not any("missing)" in r for r in decision["reasons"]), decision["reasons"]
    assert any("B-ac at B reported 0 axles" in r for r in decision["reasons"])


def test_f3_a_true_shortfall_still_proves_the_loss(line: Line) -> None:
    decision = counted(line, 16, 12, read=False)["decision"]
    assert decision["verdict"] == "incomplete", decision
    assert line.section()["state"] == "alarm"


# --- G2: a live reader that said nothing is named -------------------------------------------


def test_g2_a_live_reader_that_reported_nothing_is_named(line: Line) -> None:
    """B's wheel-mark reader is alive (heartbeat) but reported no car of this train; the IR
    readers, counters and camera agree. Missing evidence of a live device contradicts
    nothing (clearance.md rule 2): complete, with a note that it is missing."""
    decision = counted(line, 16, 16, read=True)["decision"]
    assert decision["verdict"] == "complete", decision
    assert line.section()["state"] == "free"
    assert (
        "device B-wm at B is alive but reported nothing for this train: its evidence is missing"
        in decision["reasons"]
    ), decision["reasons"]
    assert not any("B-ir" in r or "B-ac" in r for r in decision["reasons"]), decision["reasons"]


def test_f4_a_departure_reader_silent_while_the_train_left_is_a_doubt(clocked: Line) -> None:
    """The same hole at the other end (found in review): A's wheel-mark reader, silent for
    nine minutes while the train drew up and left, heard again 30 s before the departure,
    was alive at the departure's moment, and its missing consist was no doubt."""
    at = T0 - 11 * MINUTE
    while at <= T0 - 20 * SECOND:
        clocked.keep_alive(
            at, at, tuple(d for d in DEPARTURE_END if d != "A-wm" or at <= T0 - 10 * MINUTE)
        )
        at += 45 * SECOND
    clocked.post("A-wm", "heartbeat", T0 - 30 * SECOND)
    clocked.read("A", CARS, T0 - 30 * SECOND)
    run = clocked.depart(T0)
    count(clocked, "A-ac", 16, T0 + 15 * SECOND)
    clocked.keep_alive(ARRIVE - 11 * MINUTE, ARRIVE - 20 * SECOND)
    clocked.read("B", CARS, ARRIVE - 40 * SECOND)
    count(clocked, "B-ac", 16, ARRIVE - 20 * SECOND)
    clocked.snapshot("B-cam", ARRIVE - 5 * SECOND, jpeg(disc=True))
    clocked.arrive(ARRIVE)
    decision = run_of(clocked, run)["decision"]
    assert decision["verdict"] == "undetermined", decision
    assert clocked.section()["state"] == "review"
    assert any(
        r.startswith("device A-wm was silent from") and "while the train passed" in r
        for r in decision["reasons"]
    ), decision["reasons"]
