"""A decision says which look at the run it was taken on (an independent trial, F2): a run
under review, a late image proving a loss turns the section to ALARM, and a ``clear`` sent with
the revision read before is refused (409, nothing recorded), saying what changed."""

from __future__ import annotations

import re
from typing import Any

import httpx
from fastapi.testclient import TestClient
from sqlalchemy.orm import Session

from service import features
from service.replay import replay
from tests.conftest import ADMIN
from tests.service.reviewkit import late_photo_without_disc, review_run
from tests.service.scenario import Line

REASON = "camera image looked ok to me"


def audit_count(client: TestClient) -> int:
    return len(client.get("/api/v1/audit", headers=ADMIN).json())


def look(line: Line, run: int) -> httpx.Response:
    answer: httpx.Response = line.client.get(f"/api/v1/runs/{run}", headers=ADMIN)
    assert answer.status_code == 200, answer.text
    return answer


def clear(
    line: Line, run: int, who: dict[str, str], headers: dict[str, str] | None = None, **body: Any
) -> httpx.Response:
    answer: httpx.Response = line.client.post(
        f"/api/v1/runs/{run}/decision",
        json={"action": "clear", "reason": REASON, **body},
        headers={**who, **(headers or {})},
    )
    return answer


def test_a_clear_on_an_old_look_is_refused_naming_what_changed(
    line: Line, dispatcher: dict[str, str]
) -> None:
    run = review_run(line)
    seen = look(line, run)
    assert seen.headers["etag"] == f'"{seen.json()["revision"]}"'
    late_photo_without_disc(line)
    assert line.section()["state"] == "alarm"
    for sent in (
        {"headers": {"If-Match": seen.headers["etag"]}},
        {"seen": seen.json()["revision"]},
    ):
        refused = clear(line, run, dispatcher, **sent)
        assert refused.status_code == 409, refused.text
        assert refused.headers["content-type"].startswith("application/problem+json")
        detail = refused.json()["detail"]
        assert "the run changed since you looked" in detail, detail
        assert "verdict now incomplete (was undetermined)" in detail, detail
        assert "section now ALARM (was under review)" in detail, detail
        assert "look again" in detail and "Nothing was recorded" in detail, detail
    assert audit_count(line.client) == 0
    assert line.section()["state"] == "alarm"


def test_a_decision_on_the_current_look_is_taken(line: Line, dispatcher: dict[str, str]) -> None:
    run = review_run(line)
    late_photo_without_disc(line)
    now = look(line, run)
    assert now.json()["revision"].startswith("incomplete.alarm.")
    kept = line.client.post(
        f"/api/v1/runs/{run}/decision",
        json={"action": "keep_blocked", "reason": "B confirms a car short", "seen": "x"},
        headers={**dispatcher, "If-Match": now.headers["etag"]},
    )
    assert kept.status_code == 409, "each look said must be current: the body's is not"
    kept = line.client.post(
        f"/api/v1/runs/{run}/decision",
        json={"action": "keep_blocked", "reason": "B confirms a car short"},
        headers={**dispatcher, "If-Match": f'"other", {now.headers["etag"]}'},
    )
    assert kept.status_code == 200, kept.text
    assert kept.json()["state"] == "blocked"
    # the action is part of the run's revision: the look before it is old now
    assert look(line, run).json()["revision"] != now.json()["revision"]
    refused = clear(line, run, dispatcher, seen=now.json()["revision"])
    assert refused.status_code == 409
    assert "section now blocked (was ALARM)" in refused.json()["detail"]
    assert audit_count(line.client) == 1


def test_without_a_revision_a_decision_is_taken_as_before(
    line: Line, dispatcher: dict[str, str]
) -> None:
    """The precondition is optional for API clients (the README asks them to send it)."""
    run = review_run(line)
    late_photo_without_disc(line)
    assert clear(line, run, dispatcher).status_code == 200
    assert clear(line, run, dispatcher, headers={"If-Match": "*"}).status_code == 409  # already
    assert line.section()["state"] == "free"
    assert audit_count(line.client) == 1


def test_every_run_and_the_queue_carry_the_revision(line: Line) -> None:
    run = review_run(line)
    revision = look(line, run).json()["revision"]
    section = line.section()
    assert section["run"]["revision"] == revision
    items = line.client.get("/api/v1/runs", headers=ADMIN).json()["items"]
    assert [r["revision"] for r in items if r["id"] == run] == [revision]


def test_a_replayed_decision_is_re_applied(client: TestClient, session: Session) -> None:
    """The audit keeps no revision: ``depot replay`` re-applies a decision taken with one,
    even though the run's revision is another when replayed (the check is the endpoint's)."""
    from service.setup.service import create_user
    from tests.service.linekit import build_line

    features.install()
    line = Line(client, build_line(client))
    token = create_user(session, "olena", "dispatcher")
    session.commit()
    run = review_run(line)
    seen = look(line, run).headers["etag"]
    answer = clear(line, run, {"Authorization": f"Bearer {token}"}, headers={"If-Match": seen})
    assert answer.status_code == 200, answer.text
    late_photo_without_disc(line)  # late proof of a loss after the clear: alarm again
    before = line.client.get(f"/api/v1/runs/{run}", headers=ADMIN).json()
    state = line.section()["state"]
    assert state == "alarm"

    counts = replay(session)
    session.commit()
    assert counts["failed"] == 0 and counts["actions"] == 1
    after = line.client.get(f"/api/v1/runs/{run}", headers=ADMIN).json()
    assert after["overrides"][0]["action"] == "clear"
    assert after["revision"] == before["revision"]
    assert line.section()["state"] == state


def test_a_nul_in_a_reason_is_named(line: Line, dispatcher: dict[str, str]) -> None:
    """F5: the database refused it, naming no field; now the field is named, nothing kept."""
    run = review_run(line)
    refused = line.client.post(
        f"/api/v1/runs/{run}/decision",
        json={"action": "keep_blocked", "reason": "a\u0000bc"},
        headers=dispatcher,
    )
    assert refused.status_code == 422, refused.text
    errors = refused.json()["errors"]
    assert [e["loc"] for e in errors] == [["body", "reason"]]
    assert "NUL" in errors[0]["msg"]
    assert audit_count(line.client) == 0


def test_a_nul_in_a_station_name_is_named(client: TestClient) -> None:
    refused = client.post(
        "/api/v1/stations", json={"id": "N1", "name": "Bir\u0000zula"}, headers=ADMIN
    )
    assert refused.status_code == 422, refused.text
    assert [e["loc"] for e in refused.json()["errors"]] == [["body", "name"]]


def test_the_review_form_refuses_an_old_look_and_a_nul(
    line: Line, dispatcher: dict[str, str]
) -> None:
    """The form without the page's script (a plain POST) sends the hidden ``seen`` too."""
    run = review_run(line)
    login = line.client.post("/review/login", data={"token": dispatcher["Authorization"][7:]})
    assert login.status_code == 200
    page = line.client.get(f"/review?run={run}").text
    drawn = re.search(r'name="seen" value="([^"]+)"', page)
    assert drawn is not None and drawn.group(1) == look(line, run).json()["revision"]
    late_photo_without_disc(line)
    form = {"action": "clear", "reason": REASON, "seen": drawn.group(1)}
    answer = line.client.post(f"/review/runs/{run}/decision", data=form)
    assert "the run changed since you looked" in answer.text
    scripted = line.client.post(
        f"/review/runs/{run}/decision", data=form, headers={"Accept": "application/json"}
    )
    assert scripted.status_code == 409
    assert "section now ALARM (was under review)" in scripted.json()["message"]
    nul = {"action": "keep_blocked", "reason": "a\u0000bc"}
    assert "NUL" in line.client.post(f"/review/runs/{run}/decision", data=nul).text
    assert audit_count(line.client) == 0
    assert line.section()["state"] == "alarm"
