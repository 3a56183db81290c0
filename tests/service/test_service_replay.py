"""``depot replay`` rebuilds every derived table from the raw events and the audit."""

from __future__ import annotations

from datetime import timedelta
from typing import Any

from fastapi.testclient import TestClient
from sqlalchemy.orm import Session

from service import features
from service.replay import replay
from tests.conftest import ADMIN
from tests.service.linekit import build_line
from tests.service.scenario import T0, Line, jpeg


def snapshot_of_state(client: TestClient) -> dict[str, Any]:
    sections = client.get("/api/v1/sections", headers=ADMIN).json()
    runs = client.get("/api/v1/runs?limit=100", headers=ADMIN).json()["items"]
    for run in runs:
        for override in run["overrides"]:
            override.pop("evidence")  # the audit keeps the evidence as it stood then
    return {"sections": sections, "runs": runs}


def test_replay_rebuilds_the_same_state(client: TestClient, session: Session) -> None:
    features.install()
    line = Line(client, build_line(client))
    arrive = T0 + timedelta(minutes=20)
    line.heartbeat_all(T0 - timedelta(seconds=20))
    line.read("A", [117, 118, 119, 120], T0 - timedelta(seconds=30))
    line.snapshot("A-cam", T0 - timedelta(seconds=10), jpeg(disc=True, seed=1))
    run = line.depart()
    line.heartbeat_all(arrive - timedelta(seconds=20))
    line.read("B", [117, 118], arrive - timedelta(seconds=40))
    line.arrive(arrive)
    decided = client.post(
        f"/api/v1/runs/{run}/decision",
        headers=ADMIN,
        json={"action": "keep_blocked", "reason": "two cars missing"},
    )
    assert decided.status_code == 200
    line.depart(arrive + timedelta(minutes=5), train="2043")  # a conflict: AB is blocked
    before = snapshot_of_state(client)
    assert before["sections"][0]["state"] == "alarm"

    counts = replay(session)
    session.commit()
    assert counts["failed"] == 0 and counts["actions"] == 1 and counts["events"] > 20
    assert snapshot_of_state(client) == before
