"""Two trains in one section, their events delivered in every kind of order (HTTP one by one,
or one broker batch): whatever the order, each arrival closes its own train's run, the section
is never ``free`` while a run in it is unresolved, the dispatcher can resolve every run (no
dead 409), and replay rebuilds the same state."""

from __future__ import annotations

import random
from datetime import timedelta
from typing import Any

import pytest
from fastapi.testclient import TestClient
from sqlalchemy.orm import Session

from service.replay import replay
from tests.conftest import ADMIN
from tests.service.conflictkit import Broker, decide
from tests.service.scenario import T0, Line
from tests.service.test_service_replay import snapshot_of_state

# (device, kind, minutes after T0, train): 2043 departs 3 min behind 2041, both reach B.
EVENTS = [
    ("A-ilk", "train_departed", 0, "2041"),
    ("A-ilk", "train_departed", 3, "2043"),
    ("B-ilk", "train_arrived", 20, "2041"),
    ("B-ilk", "train_arrived", 23, "2043"),
    ("B-ac", "axle_count", 19, None),
]
ORDERS = [random.Random(seed).sample(range(len(EVENTS)), len(EVENTS)) for seed in range(10)]


def _fields(index: int) -> tuple[str, str, Any, dict[str, Any]]:
    device, kind, minutes, train = EVENTS[index]
    fields: dict[str, Any] = {"section": "AB"}
    fields.update({"train": train} if train else {"axles": 16})
    return device, kind, T0 + timedelta(minutes=minutes), fields


def _runs(line: Line) -> dict[str, dict[str, Any]]:
    items = line.client.get("/api/v1/runs?section=AB", headers=ADMIN).json()["items"]
    return {run["train"]: run for run in items}


def _check_and_resolve(line: Line, client: TestClient, session: Session, d: dict[str, str]) -> None:
    runs = _runs(line)
    assert set(runs) == {"2041", "2043"}, runs
    for run in runs.values():
        assert run["arrived_at"] is not None, run
        assert run["decision"]["verdict"] == "undetermined", run  # two trains: a person looks
    assert runs["2041"]["arrived_at"] == "2026-11-23T10:20:00Z"
    assert runs["2043"]["arrived_at"] == "2026-11-23T10:23:00Z"
    before = snapshot_of_state(client)
    counts = replay(session)
    session.commit()
    assert counts["failed"] == 0 and snapshot_of_state(client) == before
    for _ in range(2):
        section = line.section()
        assert section["state"] != "free", section
        decide(line, d, section["last_run_id"])
    assert line.section()["state"] == "free" and line.section()["conflict_runs"] == []


@pytest.mark.parametrize("order", ORDERS, ids=["-".join(map(str, o)) for o in ORDERS])
def test_any_http_order(
    line: Line, client: TestClient, session: Session, dispatcher: dict[str, str], order: list[int]
) -> None:
    line.heartbeat_all(T0 - timedelta(seconds=20))
    for index in order:
        device, kind, at, fields = _fields(index)
        line.post(device, kind, at, **fields)
        if line.client.get("/api/v1/runs?section=AB", headers=ADMIN).json()["items"]:
            assert line.section()["state"] != "free", (index, line.section())
    _check_and_resolve(line, client, session, dispatcher)


@pytest.mark.parametrize("order", ORDERS[:4], ids=["-".join(map(str, o)) for o in ORDERS[:4]])
def test_any_broker_order(
    line: Line, client: TestClient, session: Session, dispatcher: dict[str, str], order: list[int]
) -> None:
    line.heartbeat_all(T0 - timedelta(seconds=20))
    broker = Broker(session)
    items = []
    for index in order:
        device, kind, at, fields = _fields(index)
        items.append((device, broker.body(kind, at, **fields)))
    broker.deliver(*items)
    _check_and_resolve(line, client, session, dispatcher)
