"""A train departing into a section that was not cleared (an independent trial: its arrival was
answered "no train was running", its evidence went to the old run, the run stayed ``running``
for ever and every decision on it was a 409). Each run must get its own events, be decided,
and be resolvable by the dispatcher; the section is never ``free`` while a run in it is not
resolved — whatever the order in which the events reach depot, and by HTTP or a broker."""

from __future__ import annotations

from datetime import timedelta

import pytest
from fastapi.testclient import TestClient
from sqlalchemy.orm import Session

from service.replay import replay
from tests.conftest import ADMIN
from tests.service.conflictkit import Broker, arrive, decide, depart, resolve_all, run_of
from tests.service.reviewkit import TRANSIT, review_run
from tests.service.scenario import T0, Line, jpeg
from tests.service.test_service_replay import snapshot_of_state
from tests.service.test_service_review_screen import login

ARRIVED = T0 + TRANSIT  # the first train (2041) arrives here in review
SECOND = ARRIVED + timedelta(minutes=2)  # the second train (2043) departs into it


def test_a_departure_into_a_section_in_review_gets_its_own_arrival_and_evidence(
    line: Line, dispatcher: dict[str, str]
) -> None:
    r1 = review_run(line)
    departed = depart(line, SECOND, "2043")
    r2 = departed["run"]
    assert departed["conflict"] is True and line.section()["state"] == "alarm"
    line.heartbeat_all(SECOND + timedelta(minutes=3))
    # the second train's tail photo, dated inside the first run's window after its arrival
    photo = line.snapshot("B-cam", SECOND + timedelta(minutes=4), jpeg(disc=True, seed=21))
    assert photo["run"] == r2, photo
    answer = arrive(line, SECOND + timedelta(minutes=5), "2043")
    assert answer["run"] == r2 and "warning" not in answer, answer
    assert answer["verdict"] == "undetermined", answer  # departed into an uncleared section
    assert any("2043" in r and "not cleared" in r for r in answer["reasons"]), answer
    first = run_of(line, r1)
    assert first["decision"]["verdict"] == "undetermined", first
    assert first["evidence"]["snapshot_ids"] == []
    assert line.section()["state"] == "alarm"
    decide(line, dispatcher, r2, status=409)  # r1 is worked first; the answer says so
    resolve_all(line, dispatcher, [r1, r2])
    assert run_of(line, r2)["status"] == "arrived"


def _two_trains(line: Line) -> tuple[int, int]:
    line.heartbeat_all(T0 - timedelta(seconds=20))
    r1 = depart(line, T0, "2041")["run"]
    second = depart(line, T0 + timedelta(minutes=3), "2043")
    assert second["conflict"] is True and line.section()["state"] == "alarm"
    line.heartbeat_all(T0 + timedelta(minutes=19))
    return r1, second["run"]


@pytest.mark.parametrize("order", ["ahead_first", "behind_first"])
def test_two_trains_in_the_section_each_arrival_finds_its_train(
    line: Line, dispatcher: dict[str, str], order: str
) -> None:
    r1, r2 = _two_trains(line)
    arrivals = [(ARRIVED, "2041", r1), (ARRIVED + timedelta(minutes=3), "2043", r2)]
    if order == "behind_first":
        arrivals.reverse()  # the second arrival reaches depot first (retries, a slow link)
    for at, train, run in arrivals:
        answer = arrive(line, at, train)
        assert answer["run"] == run, answer
        assert answer["verdict"] != "complete", answer
        assert line.section()["state"] not in ("free", "occupied"), line.section()
    for run in (r1, r2):
        decision = run_of(line, run)["decision"]
        assert decision["verdict"] == "undetermined", decision
    resolve_all(line, dispatcher, [r1, r2])


def test_arrivals_that_name_no_train_of_the_section_are_an_explicit_doubt(
    line: Line, dispatcher: dict[str, str]
) -> None:
    r1, r2 = _two_trains(line)
    for at, run in ((ARRIVED, r1), (ARRIVED + timedelta(minutes=3), r2)):
        answer = arrive(line, at, "9999")
        assert answer["run"] == run, answer
        assert any("9999" in r for r in answer["reasons"]), answer
    resolve_all(line, dispatcher, [r1, r2])


def test_a_run_whose_arrival_never_comes_can_be_resolved_once_the_train_behind_arrived(
    line: Line, client: TestClient, session: Session, dispatcher: dict[str, str]
) -> None:
    r1, r2 = _two_trains(line)
    decide(line, dispatcher, r1, "keep_blocked", status=409)  # both trains still inside
    assert arrive(line, ARRIVED + timedelta(minutes=3), "2043")["run"] == r2
    login(client, session, "ivan")
    assert 'value="keep_blocked"' in client.get(f"/review?run={r1}").text  # offered on screen
    decide(line, dispatcher, r1, "keep_blocked")
    assert line.section()["state"] == "blocked"
    resolve_all(line, dispatcher, [r1, r2])


def test_the_train_behind_cannot_be_cleared_when_only_the_train_ahead_arrived(
    line: Line, client: TestClient, session: Session, dispatcher: dict[str, str]
) -> None:
    """Found by an independent trial: the train ahead's arrival counted as "a train behind
    arrived", so the dispatcher could clear the second train while it was still in the section
    and the section was ``free``. Only a train that departed after this one proves it overtaken."""
    r1, r2 = _two_trains(line)
    assert arrive(line, ARRIVED, "2041")["run"] == r1
    decide(line, dispatcher, r1, "keep_blocked")
    decide(line, dispatcher, r1, "clear")
    assert line.section()["state"] == "occupied" and line.section()["last_run_id"] == r2
    answer = decide(line, dispatcher, r2, "clear", status=409)
    assert "has not arrived" in answer["detail"], answer
    decide(line, dispatcher, r2, "keep_blocked", status=409)
    assert line.section()["state"] == "occupied"
    login(client, session, "ivan")
    assert 'value="clear"' not in client.get(f"/review?run={r2}").text  # not offered either
    assert arrive(line, ARRIVED + timedelta(minutes=3), "2043")["run"] == r2
    assert line.section()["state"] != "free"


def test_an_arrival_before_its_departure_is_kept_for_the_late_departure(
    line: Line, dispatcher: dict[str, str]
) -> None:
    line.heartbeat_all(T0 - timedelta(seconds=20))
    early = arrive(line, ARRIVED, "2041")
    assert early["run"] is None and "kept" in early["warning"], early
    late = depart(line, T0, "2041")
    run = run_of(line, late["run"])
    assert run["status"] == "arrived" and run["arrived_at"] is not None, run
    assert line.section()["state"] == "review", line.section()  # no tail photo
    resolve_all(line, dispatcher, [late["run"]])


def test_an_early_arrival_in_a_section_in_review_is_not_the_old_runs(
    line: Line, dispatcher: dict[str, str]
) -> None:
    r1 = review_run(line)
    early = arrive(line, SECOND + timedelta(minutes=20), "2043")
    assert early["run"] is None, early
    r2 = depart(line, SECOND, "2043")["run"]
    assert run_of(line, r2)["arrived_at"] is not None
    assert run_of(line, r1)["arrived_at"] == "2026-11-23T10:20:00Z"
    assert line.section()["state"] == "alarm"
    resolve_all(line, dispatcher, [r1, r2])


def test_retried_departure_and_arrival_change_nothing(
    line: Line, dispatcher: dict[str, str]
) -> None:
    r1 = review_run(line)
    body = {"event_id": "A-ilk-x1", "occurred_at": "2026-11-23T10:22:00Z",
            "kind": "train_departed", "section": "AB", "train": "2043"}  # fmt: skip
    arrival = {**body, "event_id": "B-ilk-x1", "kind": "train_arrived",
               "occurred_at": "2026-11-23T10:40:00Z"}  # fmt: skip
    for _ in range(2):
        assert line.client.post("/api/v1/events", json=body, headers=line.keys["A-ilk"]).is_success
        assert line.client.post(
            "/api/v1/events", json=arrival, headers=line.keys["B-ilk"]
        ).is_success
    runs = line.client.get("/api/v1/runs?section=AB", headers=ADMIN).json()["items"]
    section = line.section()
    assert len(runs) == 2 and section["state"] == "alarm", (section, runs)
    assert len(section["conflict_runs"]) == 1, section
    r2 = section["conflict_runs"][0]
    assert run_of(line, r2)["arrived_at"] == "2026-11-23T10:40:00Z"
    resolve_all(line, dispatcher, [r1, r2])


@pytest.mark.parametrize("order", ["departure_first", "arrival_first"])
def test_a_broker_batch_in_either_order_attributes_the_arrival(
    line: Line, session: Session, dispatcher: dict[str, str], order: str
) -> None:
    r1 = review_run(line)
    broker = Broker(session)
    departure = ("A-ilk", broker.body("train_departed", SECOND, section="AB", train="2043"))
    arrival = ("B-ilk", broker.body("train_arrived", SECOND + timedelta(minutes=18),
                                    section="AB", train="2043"))  # fmt: skip
    items = [departure, arrival] if order == "departure_first" else [arrival, departure]
    broker.deliver(*items)
    section = line.section()
    assert section["state"] == "alarm" and len(section["conflict_runs"]) == 1, section
    r2 = section["conflict_runs"][0]
    assert run_of(line, r2)["arrived_at"] is not None, run_of(line, r2)
    assert run_of(line, r1)["arrived_at"] == "2026-11-23T10:20:00Z"
    resolve_all(line, dispatcher, [r1, r2])


def test_replay_rebuilds_the_two_trains_and_their_decisions(
    line: Line, client: TestClient, session: Session, dispatcher: dict[str, str]
) -> None:
    r1, r2 = _two_trains(line)
    arrive(line, ARRIVED + timedelta(minutes=3), "2043")
    arrive(line, ARRIVED, "2041")
    decide(line, dispatcher, r1)
    before = snapshot_of_state(client)
    assert before["sections"][0]["state"] == "review"
    counts = replay(session)
    session.commit()
    assert counts["failed"] == 0 and counts["refused_actions"] == 0, counts
    assert snapshot_of_state(client) == before
    decide(line, dispatcher, r2)
    assert line.section()["state"] == "free"
