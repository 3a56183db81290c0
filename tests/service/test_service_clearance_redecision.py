"""A train-number mismatch is evidence that stays: every re-decision keeps it (late evidence
re-decides a run; the mismatch used to be passed only to the first decision, so a late tail
photo turned the run ``complete`` and freed the section with the mismatch gone)."""

from __future__ import annotations

from datetime import timedelta

from fastapi.testclient import TestClient
from sqlalchemy.orm import Session

from tests.conftest import ADMIN
from tests.service.reviewkit import TRANSIT
from tests.service.scenario import T0, Line, jpeg
from tests.service.test_service_fleet_data_rules import url  # noqa: F401 (fixture)
from tests.service.test_service_review_screen import login

MISMATCH = "arrival reported train 2014, departure train 2041"


def _mismatched_run(line: Line) -> int:
    """Four cars leave A as 2041 and reach B reported as 2014; the tail photo comes late."""
    line.heartbeat_all(T0 - timedelta(seconds=20))
    line.read("A", [117, 118, 119, 120], T0 - timedelta(seconds=30))
    run = line.depart(T0, train="2041")
    arrive = T0 + TRANSIT
    line.heartbeat_all(arrive - timedelta(seconds=30))
    line.read("B", [117, 118, 119, 120], arrive - timedelta(seconds=40))
    line.arrive(arrive, train="2014")
    return run


def test_a_late_tail_photo_keeps_the_train_number_mismatch(
    line: Line, client: TestClient, session: Session
) -> None:
    run = _mismatched_run(line)
    assert MISMATCH in line.section()["run"]["decision"]["reasons"]
    # the arrival photo, with its tail disc, comes after the arrival: the run is re-decided
    line.snapshot("B-cam", T0 + TRANSIT - timedelta(seconds=5), jpeg(disc=True, seed=3))
    assert line.section()["state"] == "review", "a mismatch never frees the section by itself"
    decision = client.get(f"/api/v1/runs/{run}", headers=ADMIN).json()["decision"]
    assert MISMATCH in decision["reasons"], decision
    assert decision["verdict"] == "undetermined", decision
    login(client, session)
    assert MISMATCH in client.get(f"/review?run={run}").text


def test_the_decision_answers_are_documented(
    line: Line, client: TestClient, dispatcher: dict[str, str]
) -> None:
    """docs/DISPATCHER.md lists every status the decision route answers (OpenAPI), the 409
    for an already decided run among them, as the API really answers it."""
    import re
    from pathlib import Path

    page = (Path(__file__).resolve().parents[2] / "docs" / "DISPATCHER.md").read_text()
    table = page.split("## `POST /api/v1/runs/{id}/decision`")[1].split("\n## ")[0]
    documented = set(re.findall(r"^\| `(\d{3})`(?: / `(\d{3})`)?", table, re.M))
    statuses = {code for pair in documented for code in pair if code}
    route = client.get("/openapi.json").json()["paths"]["/api/v1/runs/{run_id}/decision"]["post"]
    assert set(route["responses"]) <= statuses | {"default"}, (route["responses"], statuses)
    assert {"200", "401", "403", "404", "409", "422"} <= statuses
    assert "already so decided" in table
    from tests.service.reviewkit import alarm_run

    run = alarm_run(line)
    body = {"action": "keep_blocked", "reason": "two cars short"}
    assert (
        client.post(f"/api/v1/runs/{run}/decision", json=body, headers=dispatcher).status_code
        == 200
    )
    again = client.post(f"/api/v1/runs/{run}/decision", json=body, headers=dispatcher)
    assert again.status_code == 409 and "already" in again.json()["detail"], again.text


def test_migration_0010_fills_the_arrival_train_of_existing_runs(url: str) -> None:  # noqa: F811
    """Runs decided before 0010 get their arrival's train number from its raw event, so that
    their next re-decision keeps the mismatch too."""
    import sqlalchemy as sa
    from alembic import command

    from core.database import make_engine
    from service.migrate import alembic_config, upgrade
    from tests.conftest import app_on
    from tests.service.linekit import build_line

    upgrade(url)
    engine = make_engine(url)
    with TestClient(app_on(engine)) as client:
        run = _mismatched_run(Line(client, build_line(client)))
    command.downgrade(alembic_config(url), "0009_measurement_unique")
    upgrade(url)
    with engine.connect() as connection:
        trains = connection.execute(sa.text("SELECT id, train, arrival_train FROM runs")).all()
    assert [tuple(t) for t in trains] == [(run, "2041", "2014")]
    engine.dispose()
