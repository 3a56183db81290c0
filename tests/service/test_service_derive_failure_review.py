"""An event about a section whose derivation fails puts the section to a person, never leaves it
looking clear: 201 with ``derive_error`` for the device, the section in ``review`` with a fault
run on the queue in words, decided by a dispatcher like any run (``service.clearance.faults``)."""

from __future__ import annotations

from datetime import timedelta
from typing import Any

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import select
from sqlalchemy.orm import Session

from ingest import handlers as ingest_handlers
from ingest.handlers import Derivation
from ingest.models import RawEvent
from service.replay import replay
from tests.conftest import ADMIN
from tests.service.faultkit import ERROR, Breaker, fault_runs
from tests.service.scenario import T0, Line, iso, jpeg
from tests.service.test_service_clearance import departed
from tests.service.test_service_replay import snapshot_of_state
from tests.service.test_service_review_screen import login

ARRIVE = T0 + timedelta(minutes=20)


@pytest.fixture
def breaker(monkeypatch: pytest.MonkeyPatch) -> Breaker:
    return Breaker(monkeypatch)


def _next_id(line: Line, device: str) -> str:
    return f"{device}-{line.serial + 1}"  # the id Line.post gives the next event


def _decide(line: Line, run: int, action: str, who: dict[str, str]) -> Any:
    body = {"action": action, "reason": "looked at the section: empty"}
    return line.client.post(f"/api/v1/runs/{run}/decision", json=body, headers=who)


def _queue_item(line: Line) -> dict[str, Any]:
    section = line.section()
    assert section["state"] == "review", section
    return section


def test_a_failed_departure_on_a_free_section_is_for_a_person(
    line: Line, breaker: Breaker, client: TestClient, session: Session, dispatcher: dict[str, str]
) -> None:
    breaker.kinds("train_departed")
    event_id = _next_id(line, "A-ilk")
    breaker.ids.add(event_id)
    answer = line.post("A-ilk", "train_departed", T0, section="AB", train="2041")
    assert answer["derive_error"] == f"RuntimeError: {ERROR}"
    assert answer["section_state"] == "review" and "run" not in answer
    section = _queue_item(line)
    run = section["run"]
    assert run["id"] == answer["fault_run"] and run["status"] == "fault"
    assert run["decision"]["verdict"] == "undetermined"
    words = run["conflict"]
    for part in ("A-ilk", "train_departed", event_id, ERROR, "a person must look"):
        assert part in words, words
    listed = client.get("/api/v1/sections", headers=ADMIN).json()
    assert [s["state"] for s in listed if s["id"] == "AB"] == ["review"]

    login(client, session, "taras")
    page = client.get("/review").text
    assert 'data-section="AB" data-state="review"' in page
    assert f'data-run="{run["id"]}"' in page and event_id in page
    assert "could not be processed" in page
    assert 'value="clear"' in page and 'value="keep_blocked"' in page

    decided = _decide(line, run["id"], "clear", dispatcher)
    assert decided.status_code == 200, decided.text
    assert decided.json()["state"] == "free" and line.section()["state"] == "free"
    audit = client.get(f"/api/v1/audit?run={run['id']}", headers=ADMIN).json()
    assert [(a["action"], a["state_before"]) for a in audit] == [("clear", "review")]
    raw = session.scalar(select(RawEvent).where(RawEvent.event_id == event_id))
    assert raw is not None and raw.derive_error == answer["derive_error"]


def _complete_arrival(line: Line) -> dict[str, Any]:
    line.heartbeat_all(ARRIVE - timedelta(seconds=30))
    line.read("B", [117, 118, 119, 120], ARRIVE - timedelta(seconds=40))
    line.post("B-ac", "axle_count", ARRIVE - timedelta(seconds=20), section="AB", axles=16)
    line.snapshot("B-cam", ARRIVE - timedelta(seconds=5), jpeg(disc=True, seed=2))
    return line.arrive(ARRIVE)


@pytest.mark.parametrize("kind", ["axle_count", "tail_snapshot"])
def test_a_fault_on_an_occupied_section_outlasts_a_complete_arrival(
    line: Line, breaker: Breaker, dispatcher: dict[str, str], kind: str
) -> None:
    train = departed(line)
    breaker.kinds(kind)
    at = T0 + timedelta(minutes=5)
    if kind == "axle_count":
        breaker.ids.add(_next_id(line, "B-ac"))
        answer = line.post("B-ac", "axle_count", at, section="AB", axles=16)
    else:
        breaker.ids.add(_next_id(line, "B-cam"))
        answer = line.snapshot("B-cam", at, jpeg(disc=True, seed=3))
    assert answer["derive_error"] == f"RuntimeError: {ERROR}", answer
    fault = answer["fault_run"]
    section = _queue_item(line)
    assert section["run"]["id"] == train and section["fault_runs"] == [fault]

    arrived = _complete_arrival(line)
    assert arrived["verdict"] == "complete", arrived
    section = _queue_item(line)  # not freed: the fault run holds it now
    assert section["run"]["id"] == fault and section["run"]["status"] == "fault"
    assert section["fault_runs"] == []
    assert _decide(line, train, "clear", dispatcher).status_code == 409  # not the current run

    kept = _decide(line, fault, "keep_blocked", dispatcher)
    assert kept.status_code == 200 and kept.json()["state"] == "blocked", kept.text
    assert _decide(line, fault, "clear", dispatcher).json()["state"] == "free"


def test_a_waiting_fault_cannot_be_decided_before_the_run_ahead(
    line: Line, breaker: Breaker, client: TestClient, session: Session, dispatcher: dict[str, str]
) -> None:
    departed(line)
    breaker.kinds("axle_count")
    breaker.ids.add(_next_id(line, "B-ac"))
    fault = line.post("B-ac", "axle_count", T0 + timedelta(minutes=5), section="AB", axles=16)
    refused = _decide(line, fault["fault_run"], "clear", dispatcher)
    assert refused.status_code == 409 and "first" in refused.json()["detail"]
    login(client, session, "taras")
    page = client.get("/review").text
    assert f"run {fault['fault_run']} waits behind this run" in page, "the queue says why"


def test_two_faults_of_one_section_are_each_decided(
    line: Line, breaker: Breaker, dispatcher: dict[str, str]
) -> None:
    breaker.kinds("axle_count")
    faults = []
    for n in range(2):
        breaker.ids.add(_next_id(line, "A-ac"))
        at = T0 + timedelta(minutes=n)
        faults.append(line.post("A-ac", "axle_count", at, section="AB", axles=8)["fault_run"])
    section = _queue_item(line)
    assert section["run"]["id"] == faults[0] and section["fault_runs"] == [faults[1]]
    assert _decide(line, faults[0], "clear", dispatcher).json()["state"] == "review"
    assert line.section()["run"]["id"] == faults[1]
    assert _decide(line, faults[1], "clear", dispatcher).json()["state"] == "free"


def test_a_retry_of_a_failed_event_makes_no_second_fault_run(
    line: Line, breaker: Breaker, session: Session
) -> None:
    breaker.kinds("axle_count").count_hook()
    body = {"event_id": "ac-retry", "occurred_at": iso(T0), "kind": "axle_count"}
    body |= {"section": "AB", "axles": 12}
    breaker.ids.add("ac-retry")
    first = line.client.post("/api/v1/events", json=body, headers=line.keys["A-ac"])
    again = line.client.post("/api/v1/events", json=body, headers=line.keys["A-ac"])
    assert first.status_code == 201 and again.status_code == 200, again.text
    assert again.json()["status"] == "duplicate" and again.json()["derive_error"]
    assert [r.id for r in fault_runs(session)] == [first.json()["fault_run"]]
    assert breaker.hooked == ["ac-retry"]


def test_replay_puts_the_section_to_a_person_again_and_reapplies_the_decision(
    line: Line, breaker: Breaker, session: Session, dispatcher: dict[str, str]
) -> None:
    breaker.kinds("train_departed", "axle_count")
    breaker.ids.add(_next_id(line, "A-ilk"))
    decided = line.post("A-ilk", "train_departed", T0, section="AB", train="2041")["fault_run"]
    assert _decide(line, decided, "keep_blocked", dispatcher).status_code == 200
    breaker.ids.add(_next_id(line, "B-ilk"))
    line.post("B-ilk", "train_departed", T0 + timedelta(minutes=1), section="BC", train="2050")
    line.post("A-ac", "axle_count", T0 + timedelta(minutes=2), section="AB", axles=8)
    before = snapshot_of_state(line.client)
    states = {s["id"]: s["state"] for s in before["sections"]}
    assert states == {"AB": "blocked", "BC": "review"}, states

    counts = replay(session)
    session.commit()
    assert counts["failed"] == 2 and counts["actions"] == 1, counts
    assert snapshot_of_state(line.client) == before


def test_a_failing_failure_handler_still_acks_and_keeps_the_raw_event(
    line: Line, breaker: Breaker, session: Session, monkeypatch: pytest.MonkeyPatch
) -> None:
    (real,) = ingest_handlers.FAILURE_HANDLERS

    def broken(d: Derivation, error: str) -> dict[str, Any] | None:
        real(d, error)  # writes the fault run, then fails: its savepoint undoes it
        raise RuntimeError("the failure handler crashed too")

    monkeypatch.setattr(ingest_handlers, "FAILURE_HANDLERS", [broken])
    breaker.kinds("axle_count")
    event_id = _next_id(line, "A-ac")
    breaker.ids.add(event_id)
    answer = line.post("A-ac", "axle_count", T0, section="AB", axles=8)
    assert answer["derive_error"] == f"RuntimeError: {ERROR}" and "fault_run" not in answer
    raw = session.scalar(select(RawEvent).where(RawEvent.event_id == event_id))
    assert raw is not None and raw.derive_error == answer["derive_error"]
    assert fault_runs(session) == [] and line.section()["state"] == "free"


def test_late_proof_of_loss_outranks_the_fault_on_the_queue(
    line: Line, breaker: Breaker, client: TestClient, session: Session
) -> None:
    train = departed(line)
    breaker.kinds("eot_status")
    breaker.ids.add(_next_id(line, "B-eot"))
    line.post("B-eot", "eot_status", T0 + timedelta(minutes=5), section="AB", unit_address=7,
              pressure_psig=60)  # fmt: skip
    line.heartbeat_all(ARRIVE - timedelta(seconds=30))
    line.read("B", [117, 118, 119, 120], ARRIVE - timedelta(seconds=40))
    line.snapshot("B-cam", ARRIVE - timedelta(seconds=5), jpeg(disc=True, seed=2))
    assert line.arrive(ARRIVE)["verdict"] == "complete"
    assert line.section()["run"]["status"] == "fault"
    late = line.post("B-ac", "axle_count", ARRIVE - timedelta(seconds=20), section="AB", axles=12)
    assert late["reevaluated"]["verdict"] == "incomplete", late
    assert line.section()["state"] == "alarm"
    login(client, session, "taras")
    page = client.get("/review").text
    headline = page.split('<table id="queue">')[1].split("</table>")[0]
    assert f"run {train} (train 2041)" in headline and "could not be processed" not in headline


def test_a_failed_arrival_keeps_the_train_in_the_section_and_the_fault_behind_it(
    line: Line, breaker: Breaker, dispatcher: dict[str, str]
) -> None:
    train = departed(line)
    breaker.kinds("train_arrived")
    breaker.ids.add(_next_id(line, "B-ilk"))
    fault = line.arrive(ARRIVE)["fault_run"]
    section = _queue_item(line)
    assert section["run"]["id"] == train and section["run"]["status"] == "running"
    assert section["fault_runs"] == [fault]
    assert _decide(line, fault, "clear", dispatcher).status_code == 409
    arrived = _complete_arrival(line)  # the interlocking reports the arrival again, new id
    assert arrived["run"] == train and arrived["verdict"] == "complete", arrived
    assert line.section()["run"]["id"] == fault, "the fault holds the section, not free"
    assert _decide(line, fault, "clear", dispatcher).json()["state"] == "free"
