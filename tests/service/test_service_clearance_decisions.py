"""The dispatcher's decision flow, server side (issue 17): a decision asked for twice is
refused without a second audit row, by the API and by the review form alike, and a run says
which action was taken, by whom and when."""

from __future__ import annotations

import re
from datetime import UTC, datetime, timedelta

import pytest
from fastapi.testclient import TestClient
from sqlalchemy.orm import Session

from core.auth import Principal
from service.clearance.models import AuditRecord
from service.clearance.views import audit_out
from tests.conftest import ADMIN
from tests.service.scenario import T0, Line

ARRIVE = T0 + timedelta(minutes=20)


def arrived_for_review(line: Line) -> int:
    line.heartbeat_all(T0 - timedelta(seconds=20))
    run = line.depart()
    line.heartbeat_all(ARRIVE - timedelta(seconds=20))
    assert line.arrive(ARRIVE)["verdict"] == "undetermined"  # no arrival image
    return run


def audit_count(line: Line) -> int:
    return len(line.client.get("/api/v1/audit", headers=ADMIN).json())


def decide(line: Line, run: int, action: str, who: dict[str, str], reason: str = "seen it"):
    return line.client.post(
        f"/api/v1/runs/{run}/decision", json={"action": action, "reason": reason}, headers=who
    )


@pytest.mark.parametrize(
    ("first", "again"),
    [("clear", "clear"), ("keep_blocked", "keep_blocked"), ("sweep", "sweep")],
)
def test_the_same_decision_twice_is_refused_without_audit(
    line: Line, dispatcher: dict[str, str], first: str, again: str
) -> None:
    run = arrived_for_review(line)
    assert decide(line, run, first, dispatcher).status_code == 200
    before = audit_count(line)
    repeated = decide(line, run, again, dispatcher, reason="pressed twice")
    assert repeated.status_code == 409, repeated.text
    assert repeated.headers["content-type"].startswith("application/problem+json")
    assert "already" in repeated.json()["detail"]
    assert audit_count(line) == before == 1


def test_a_change_of_mind_is_still_an_action(line: Line, dispatcher: dict[str, str]) -> None:
    run = arrived_for_review(line)
    assert decide(line, run, "keep_blocked", dispatcher).status_code == 200
    assert decide(line, run, "clear", dispatcher, reason="walker saw the disc").status_code == 200
    assert decide(line, run, "keep_blocked", dispatcher, reason="again").status_code == 200
    assert audit_count(line) == 3


def test_the_review_form_refuses_a_repeated_decision_too(
    line: Line, dispatcher: dict[str, str]
) -> None:
    run = arrived_for_review(line)
    login = line.client.post("/review/login", data={"token": dispatcher["Authorization"][7:]})
    assert login.status_code == 200
    form = {"action": "keep_blocked", "reason": "sending a walker"}
    for _ in range(2):
        answer = line.client.post(f"/review/runs/{run}/decision", data=form, follow_redirects=False)
        assert answer.status_code == 303
    assert audit_count(line) == 1
    assert line.section()["state"] == "blocked"


def test_the_run_says_which_action_by_whom_and_when(line: Line, dispatcher: dict[str, str]) -> None:
    run = arrived_for_review(line)
    fresh = line.client.get(f"/api/v1/runs/{run}", headers=ADMIN).json()["decision"]
    assert fresh["action"] is None and fresh["actor"] is None and fresh["acted_at"] is None
    assert decide(line, run, "keep_blocked", dispatcher).status_code == 200
    decision = line.client.get(f"/api/v1/runs/{run}", headers=ADMIN).json()["decision"]
    assert decision["verdict"] == "undetermined" and decision["auto"] is False
    assert decision["action"] == "keep_blocked" and decision["actor"] == "olena"
    acted = datetime.fromisoformat(decision["acted_at"])
    assert abs(acted - datetime.now(UTC)) < timedelta(minutes=1)
    assert re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d(\.\d{3})?Z", decision["acted_at"])


def test_audit_views_carry_no_microseconds(session: Session) -> None:
    record = AuditRecord(
        id=1,
        run_id=7,
        section="AB",
        action="clear",
        reason="seen",
        actor=Principal(role="dispatcher", name="olena").name,
        actor_role="dispatcher",
        recorded_at=datetime(2026, 11, 23, 17, 54, 11, 123456, tzinfo=UTC),
        state_before="review",
        state_after="free",
        evidence={},
    )
    assert audit_out(record)["recorded_at"] == "2026-11-23T17:54:11.123Z"


def test_run_answer_documents_the_sweep_and_decision_fields(client: TestClient) -> None:
    schemas = client.get("/openapi.json").json()["components"]["schemas"]
    run = schemas["RunOut"]["properties"]
    for field in ("sweep", "sweep_of", "cleared_by", "eot_unit"):
        assert field in run and run[field].get("description"), field
    decision = schemas["DecisionOut"]["properties"]
    for field in ("action", "actor", "acted_at"):
        assert field in decision and decision[field].get("description"), field
