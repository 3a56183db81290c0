"""An independent trial of passage liveness: a device at either end of AB that sent nothing for
a train must have been heard by the server (by *receive* time) throughout the time the train
may have passed it, else the section goes to review naming it; an axle count of 0 is no count;
``depot replay`` rebuilds the same decisions.

Every event is played in the order the server receives it (``Plan``); the server's clock is the
test's (``tests/service/clock``). Unless a case says otherwise the line is healthy: every device
at A and B heartbeats as a live line does (each 55 s and at the end of the time it is alive,
``scenario.alive_times``), the train is read, counted and photographed at both ends.
"""

from __future__ import annotations

from datetime import datetime, timedelta
from typing import Any

import pytest
from fastapi.testclient import TestClient
from sqlalchemy.orm import Session

from tests.conftest import ADMIN
from tests.service.clock import ServerClock, server_clock  # noqa: F401 (fixture)
from tests.service.linekit import post_ok
from tests.service.livenesskit import (
    ARRIVE,
    CARS,
    ENDS,
    M,
    Plan,
    S,
    assert_free,
    assert_review_naming,
    decision,
    evidence,
    names,
    replays_the_same,
)
from tests.service.scenario import T0, Line, alive_times, iso


@pytest.fixture
def line(client: TestClient, server_clock: ServerClock) -> Line:  # noqa: F811
    return Line.clocked(client, server_clock)


def test_healthy_line_is_freed_and_replays_the_same(line: Line, session: Session) -> None:
    plan = Plan(line)
    plan.beat(ENDS, T0 - 10 * M, ARRIVE + 30 * S)
    evidence(plan)
    run = plan.play()["depart"]["run"]
    assert_free(line, run)
    replays_the_same(line, session)


def test_heartbeats_exactly_every_60s_are_alive(line: Line, session: Session) -> None:
    """Silent *longer* than the period is stale: a gap of exactly 60 s is not."""
    plan = Plan(line)
    plan.beat(ENDS, T0 - 10 * M, ARRIVE + 30 * S, step=60 * S)
    evidence(plan, skip=("B-ir",))
    run = plan.play()["depart"]["run"]
    assert_free(line, run)
    assert not any("silent" in r or "not heard" in r for r in decision(line, run)["reasons"])
    replays_the_same(line, session)


def test_a_gap_of_61s_inside_the_passage_is_silence(line: Line, session: Session) -> None:
    """A boundary case: its heartbeats keep their exact 30 s timings."""
    plan = Plan(line)
    plan.beat(set(ENDS) - {"B-ir"}, T0 - 10 * M, ARRIVE + 30 * S, step=30 * S)
    plan.beat(["B-ir"], T0 - 10 * M, ARRIVE - 3 * M, step=30 * S)
    plan.beat(["B-ir"], ARRIVE - 3 * M + 61 * S, ARRIVE + 30 * S, step=30 * S)
    evidence(plan, skip=("B-ir",))
    run = plan.play()["depart"]["run"]
    assert_review_naming(line, run, "B-ir")
    replays_the_same(line, session)


def test_devices_that_never_see_the_train_do_not_matter(line: Line, session: Session) -> None:
    """The marking station, test bench and on-board unit (station A, no section), the EOT
    receiver (the train carries no EOT unit) and a reader at B on section BC are silent: AB's
    train is still proven complete."""
    post_ok(
        line.client,
        "/api/v1/devices",
        {"id": "B-ir-BC", "station": "B", "section": "BC", "kind": "ir_reader"},
    )
    plan = Plan(line)
    plan.beat(set(ENDS) - {"B-eot"}, T0 - 10 * M, ARRIVE + 30 * S)
    evidence(plan)
    run = plan.play()["depart"]["run"]
    assert_free(line, run)
    replays_the_same(line, session)


def test_heartbeats_in_batches_keep_a_device_alive(line: Line, session: Session) -> None:
    plan = Plan(line)
    plan.beat(set(ENDS) - {"B-ir", "B-wm"}, T0 - 10 * M, ARRIVE + 30 * S)
    for n, at in enumerate(alive_times(T0 - 10 * M, ARRIVE + 30 * S)):

        def send(at: datetime = at, n: int = n) -> None:
            line.clock.set(at)  # type: ignore[union-attr]
            body = {
                "events": [
                    {"event_id": f"bir-hb-{n}", "occurred_at": iso(at), "kind": "heartbeat"},
                ]
            }
            answer = line.client.post("/api/v1/events", json=body, headers=line.keys["B-ir"])
            assert answer.status_code == 200, answer.text
            answer = line.client.post(
                "/api/v1/events",
                json={"events": [{**body["events"][0], "event_id": f"bwm-hb-{n}"}]},
                headers=line.keys["B-wm"],
            )
            assert answer.status_code == 200, answer.text

        plan.add(at, send)
    evidence(plan)
    run = plan.play()["depart"]["run"]
    assert_free(line, run)
    replays_the_same(line, session)


def test_a_silent_device_that_reported_counts(line: Line, session: Session) -> None:
    """B-ir, B-ac and B-cam heard nothing but their reports: what they reported counts."""
    plan = Plan(line)
    plan.beat(set(ENDS) - {"B-ir", "B-ac", "B-cam"}, T0 - 10 * M, ARRIVE + 30 * S)
    plan.beat(["B-ir", "B-ac", "B-cam"], T0 - 10 * M, T0 - 5 * M)
    evidence(plan)
    run = plan.play()["depart"]["run"]
    assert_free(line, run)
    replays_the_same(line, session)


def test_a_long_journey_with_silence_far_from_the_passage(line: Line, session: Session) -> None:
    """3 h journey; B-ir is silent an hour in the middle (the train is far from B)."""
    arrive = T0 + 3 * timedelta(hours=1)
    plan = Plan(line)
    plan.beat(set(ENDS) - {"B-ir"}, T0 - 10 * M, arrive + 30 * S, step=60 * S)
    plan.beat(["B-ir"], T0 - 10 * M, T0 + 60 * M, step=60 * S)
    plan.beat(["B-ir"], T0 + 120 * M, arrive + 30 * S, step=60 * S)
    evidence(plan, arrive)
    run = plan.play()["depart"]["run"]
    assert_free(line, run)
    replays_the_same(line, session)


def test_device_clock_years_behind_still_heartbeats_by_receive_time(
    line: Line, session: Session
) -> None:
    """B-ir's clock says 2001 (1999 is refused: times before 2000 are 422) but the server hears
    it as a live line (each 55 s): alive (named: reported nothing), the train is complete."""
    plan = Plan(line)
    plan.beat(set(ENDS) - {"B-ir"}, T0 - 10 * M, ARRIVE + 30 * S)
    plan.beat(
        ["B-ir"],
        T0 - 10 * M,
        ARRIVE + 30 * S,
        dated=lambda at: at.replace(year=2001),
    )
    evidence(plan, skip=("B-ir",))
    run = plan.play()["depart"]["run"]
    assert_free(line, run)
    assert names(line, run, "B-ir"), decision(line, run)
    replays_the_same(line, session)


# --- silence that must not free -------------------------------------------------------------


def test_arrival_reader_silent_through_the_passage(line: Line, session: Session) -> None:
    plan = Plan(line)
    plan.beat(set(ENDS) - {"B-ir"}, T0 - 10 * M, ARRIVE + 30 * S)
    plan.beat(["B-ir"], T0 - 10 * M, ARRIVE - 5 * M)
    evidence(plan, skip=("B-ir",))
    run = plan.play()["depart"]["run"]
    named = assert_review_naming(line, run, "B-ir")
    assert any(":" in r and "10:" in r for r in named), named  # the times it was not heard
    replays_the_same(line, session)


def test_device_clock_2030_heartbeats_are_refused_so_it_is_silent(
    line: Line, session: Session
) -> None:
    """B-ir's clock is in 2030: its heartbeats are refused (422), the server hears nothing."""
    plan = Plan(line)
    plan.beat(set(ENDS) - {"B-ir"}, T0 - 10 * M, ARRIVE + 30 * S)

    def far_ahead(at: datetime) -> None:
        line.clock.set(at)  # type: ignore[union-attr]
        body = {"event_id": f"bir-{at:%H%M%S}", "occurred_at": "2030-01-01T00:00:00Z"}
        answer = line.client.post(
            "/api/v1/events", json={**body, "kind": "heartbeat"}, headers=line.keys["B-ir"]
        )
        assert answer.status_code == 422, answer.text

    at = T0 - 5 * M
    while at <= ARRIVE:
        plan.add(at, lambda at=at: far_ahead(at))  # type: ignore[misc]
        at += 30 * S
    plan.beat(["B-ir"], T0 - 10 * M, T0 - 6 * M)
    evidence(plan, skip=("B-ir",))
    run = plan.play()["depart"]["run"]
    assert_review_naming(line, run, "B-ir")
    replays_the_same(line, session)


def test_buffered_heartbeats_flushed_in_one_batch_are_one_instant(
    line: Line, session: Session
) -> None:
    """B-ir's link is down from T0+1 min; just before the arrival it flushes every heartbeat
    it took meanwhile (dated each 30 s) in one batch. The server heard it once: silent."""
    plan = Plan(line)
    plan.beat(set(ENDS) - {"B-ir"}, T0 - 10 * M, ARRIVE + 30 * S)
    plan.beat(["B-ir"], T0 - 10 * M, T0 + M)
    flush = ARRIVE - 10 * S

    def flush_batch() -> None:
        line.clock.set(flush)  # type: ignore[union-attr]
        events = []
        at = T0 + 90 * S
        while at <= flush:
            events.append(
                {"event_id": f"bir-b{at:%H%M%S}", "occurred_at": iso(at), "kind": "heartbeat"}
            )
            at += 30 * S
        answer = line.client.post(
            "/api/v1/events", json={"events": events}, headers=line.keys["B-ir"]
        )
        assert answer.status_code == 200, answer.text
        assert {r["status"] for r in answer.json()["results"]} == {"created"}

    plan.add(flush, flush_batch)
    evidence(plan, skip=("B-ir",))
    run = plan.play()["depart"]["run"]
    assert_review_naming(line, run, "B-ir")
    replays_the_same(line, session)


def test_decommissioned_after_the_decision_replays_the_same(line: Line, session: Session) -> None:
    plan = Plan(line)
    plan.beat(set(ENDS) - {"B-ir"}, T0 - 10 * M, ARRIVE + 30 * S)
    plan.beat(["B-ir"], T0 - 10 * M, ARRIVE - 5 * M)
    evidence(plan, skip=("B-ir",))
    run = plan.play()["depart"]["run"]
    assert_review_naming(line, run, "B-ir")
    line.clock.set(ARRIVE + 5 * M)  # type: ignore[union-attr]
    answer = line.client.post("/api/v1/devices/B-ir/decommission", headers=ADMIN)
    assert answer.status_code == 200, answer.text
    replays_the_same(line, session)
    assert_review_naming(line, run, "B-ir")


def test_decommissioned_mid_journey_while_silent(line: Line, session: Session) -> None:
    """B-ir went silent at ARRIVE-5 min and was decommissioned at ARRIVE-1 min: for 4 min of
    the arrival window it was a registered, silent device while the train may have passed it."""
    plan = Plan(line)
    plan.beat(set(ENDS) - {"B-ir"}, T0 - 10 * M, ARRIVE + 30 * S)
    plan.beat(["B-ir"], T0 - 10 * M, ARRIVE - 5 * M)

    def decommission() -> None:
        line.clock.set(ARRIVE - M)  # type: ignore[union-attr]
        answer = line.client.post("/api/v1/devices/B-ir/decommission", headers=ADMIN)
        assert answer.status_code == 200, answer.text

    plan.add(ARRIVE - M, decommission)
    evidence(plan, skip=("B-ir",))
    run = plan.play()["depart"]["run"]
    assert_review_naming(line, run, "B-ir")
    replays_the_same(line, session)


@pytest.mark.parametrize("heard", [True, False])
def test_registered_mid_journey(line: Line, session: Session, heard: bool) -> None:
    """A second IR reader at B is registered 5 min before the arrival; heartbeating, it is a
    live reader that reported nothing (named, still complete); never heard, silent 5 min."""

    def register() -> None:
        line.clock.set(ARRIVE - 5 * M)  # type: ignore[union-attr]
        body = {"id": "B-ir2", "station": "B", "section": "AB", "kind": "ir_reader"}
        line.keys["B-ir2"] = {"X-Device-Key": post_ok(line.client, "/api/v1/devices", body)["key"]}

    plan = Plan(line)
    plan.beat(ENDS, T0 - 10 * M, ARRIVE + 30 * S)
    plan.add(ARRIVE - 5 * M, register)
    if heard:
        at = ARRIVE - 5 * M + S
        while at <= ARRIVE:
            plan.add(at, lambda at=at: line.post("B-ir2", "heartbeat", at))  # type: ignore[misc]
            at += 30 * S
    evidence(plan)
    run = plan.play()["depart"]["run"]
    if heard:
        assert_free(line, run)
        assert names(line, run, "B-ir2"), decision(line, run)
    else:
        assert_review_naming(line, run, "B-ir2")
    replays_the_same(line, session)


# --- late evidence ---------------------------------------------------------------------------


def test_late_reads_of_a_silent_reader_decide_again_and_replay(
    line: Line, session: Session
) -> None:
    """B-ir is silent through the passage (review); 3 min after the arrival its backlog arrives:
    the 4 cars, dated at the passage. A late report counts: the train is complete."""
    plan = Plan(line)
    plan.beat(set(ENDS) - {"B-ir"}, T0 - 10 * M, ARRIVE + 4 * M)
    plan.beat(["B-ir"], T0 - 10 * M, ARRIVE - 5 * M)
    evidence(plan, skip=("B-ir",))
    for i, car in enumerate(CARS):
        plan.post(
            "B-ir",
            "ir_id",
            ARRIVE - 40 * S + i * S,
            received=ARRIVE + 3 * M + i * S,
            section="AB",
            reads=[car] * 5,
        )
    results = plan.play()
    run = results["depart"]["run"]
    assert results["arrive"]["verdict"] == "undetermined", results["arrive"]
    assert decision(line, run)["verdict"] == "complete", decision(line, run)
    replays_the_same(line, session)


# --- axle counts of 0 and odd numbers --------------------------------------------------------


@pytest.mark.parametrize("axles", [(0, 0), (16, 0), (0, 16)], ids=str)
def test_zero_axle_counts_are_no_count(
    line: Line, session: Session, axles: tuple[int, int]
) -> None:
    plan = Plan(line)
    plan.beat(ENDS, T0 - 10 * M, ARRIVE + 30 * S)
    evidence(plan, axles=axles)
    run = plan.play()["depart"]["run"]
    decided = decision(line, run)
    assert not any("axle counts agree" in r for r in decided["reasons"]), decided
    assert decided["verdict"] == "undetermined", decided
    assert line.section()["state"] == "review", line.section()
    replays_the_same(line, session)


@pytest.mark.parametrize("axles", [-1, 2**63, 10**30, True, 16.5, "16"], ids=repr)
def test_odd_axle_counts_are_refused(line: Line, axles: Any) -> None:
    line.clock.set(T0)  # type: ignore[union-attr]
    body = {
        "event_id": f"B-ac-odd-{axles!r}"[:60],
        "occurred_at": iso(T0),
        "kind": "axle_count",
        "section": "AB",
        "axles": axles,
    }
    answer = line.client.post("/api/v1/events", json=body, headers=line.keys["B-ac"])
    assert answer.status_code == 422, (axles, answer.status_code, answer.text)
