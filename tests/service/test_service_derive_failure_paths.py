"""Every way an event is stored reaches the failure handler once per failed derivation, never for
its neighbours: the HTTP group commit (PostgreSQL; the group redone event by event), a group of
one, an HTTP batch, and the broker batches of MQTT and NATS (``transports.envelope.handle_batch``:
optimistic, redone message by message), on committed sessions."""

from __future__ import annotations

import json
from collections.abc import Iterator
from datetime import timedelta
from typing import Any, cast

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import Engine, select
from sqlalchemy.orm import Session, sessionmaker

from core.auth import device_cache
from core.models import Device, Section
from core.settings import get_settings
from ingest.checks import parse_event
from ingest.commit_queue import GroupCommitter, _Pending
from ingest.models import RawEvent
from ingest.service import store_group, store_validated
from tests.conftest import ADMIN
from tests.service.faultkit import ERROR, Breaker, fault_runs
from tests.service.linekit import build_line, event
from tests.service.scenario import T0, iso
from transports.envelope import Message, handle_batch


@pytest.fixture
def breaker(monkeypatch: pytest.MonkeyPatch) -> Breaker:
    return Breaker(monkeypatch)


@pytest.fixture
def keys(committed_app: Any) -> Iterator[tuple[TestClient, dict[str, str]]]:
    """The test line on committing sessions: a client and each device's key."""
    with TestClient(committed_app) as client:
        headers = build_line(client)
        yield client, {d: h["X-Device-Key"] for d, h in headers.items()}
    device_cache().invalidate()  # the keys name devices the clean-up removes


def _counts(n: int) -> list[tuple[str, dict[str, Any]]]:
    """Axle counts ``ac-0`` … on AB from both ends."""
    return [
        (
            "A-ac" if i % 2 == 0 else "B-ac",
            event(f"ac-{i}", "axle_count", iso(T0 + timedelta(seconds=i)), section="AB", axles=16),
        )
        for i in range(n)
    ]


def _stored(engine: Engine) -> tuple[dict[str, str | None], str, list[int]]:
    """Each raw event's derive_error, AB's state and its fault runs."""
    with Session(engine) as session:
        raws = {r.event_id: r.derive_error for r in session.scalars(select(RawEvent))}
        section = session.get_one(Section, "AB")
        return raws, section.state, [r.id for r in fault_runs(session)]


def test_a_group_commit_reaches_the_failure_handler_once_per_failed_event(
    keys: tuple[TestClient, dict[str, str]], engine: Engine, breaker: Breaker
) -> None:
    breaker.kinds("axle_count").count_hook()
    items = _counts(6)
    breaker.ids.update({"ac-1", "ac-4"})
    factory = sessionmaker(engine, expire_on_commit=False)
    with factory() as session:
        group = [
            _Pending(session.get_one(Device, d), parse_event(b), b, cast(Any, None))
            for d, b in items
        ]
    committer = GroupCommitter(
        factory, store_group, store_validated, window_s=0.0, max_events=len(group)
    )
    outcomes = committer._commit(group)
    assert [o[0] for o in outcomes if isinstance(o, tuple)] == [201] * 6, outcomes
    answers = {o[1]["event_id"]: o[1] for o in outcomes if isinstance(o, tuple)}
    assert sorted(e for e, a in answers.items() if "derive_error" in a) == ["ac-1", "ac-4"]
    assert sorted(breaker.hooked) == ["ac-1", "ac-4"], "once each, never for a neighbour"
    raws, state, faults = _stored(engine)
    failed = f"RuntimeError: {ERROR}"
    assert raws == {f"ac-{i}": (failed if i in (1, 4) else None) for i in range(6)}
    assert state == "review" and len(faults) == 2


def test_a_single_event_through_the_group_commit_is_acked_with_its_fault(
    keys: tuple[TestClient, dict[str, str]],
    engine: Engine,
    breaker: Breaker,
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    if engine.dialect.name != "postgresql":
        pytest.skip("group commit runs on PostgreSQL only")
    monkeypatch.setenv("DEPOT_GROUP_COMMIT_MS", "2")
    get_settings.cache_clear()
    client, key = keys
    breaker.kinds("train_departed").count_hook()
    breaker.ids.add("dep-1")
    body = event("dep-1", "train_departed", iso(T0), section="AB", train="2041")
    answer = client.post("/api/v1/events", json=body, headers={"X-Device-Key": key["A-ilk"]})
    get_settings.cache_clear()
    assert answer.status_code == 201, answer.text
    assert answer.json()["derive_error"] == f"RuntimeError: {ERROR}"
    assert breaker.hooked == ["dep-1"]
    section = client.get("/api/v1/sections/AB", headers=ADMIN).json()
    assert section["state"] == "review" and section["run"]["status"] == "fault"


def test_an_http_batch_puts_only_its_failed_item_to_a_person(
    keys: tuple[TestClient, dict[str, str]], engine: Engine, breaker: Breaker
) -> None:
    client, key = keys
    breaker.kinds("axle_count").count_hook()
    breaker.ids.add("ac-2")
    batch = {"events": [b for d, b in _counts(5) if d == "A-ac"]}  # ac-0, ac-2, ac-4
    answer = client.post("/api/v1/events", json=batch, headers={"X-Device-Key": key["A-ac"]})
    assert answer.status_code == 200, answer.text
    results = {r["event_id"]: r for r in answer.json()["results"]}
    assert [r["status"] for r in results.values()] == ["created"] * 3
    assert "fault_run" in results["ac-2"]["result"] and "derive_error" in results["ac-2"]["result"]
    assert "derive_error" not in results["ac-0"]["result"]
    assert breaker.hooked == ["ac-2"]
    _, state, faults = _stored(engine)
    assert state == "review" and len(faults) == 1


@pytest.mark.parametrize("transport", ["mqtt", "nats"])
def test_a_broker_batch_redone_message_by_message_reaches_the_hook_once(
    keys: tuple[TestClient, dict[str, str]], engine: Engine, breaker: Breaker, transport: str
) -> None:
    _, key = keys
    breaker.kinds("axle_count").count_hook()
    breaker.ids.add("ac-3")
    messages = [Message(d, key[d], json.dumps(b).encode()) for d, b in _counts(5)]
    sessions = sessionmaker(engine, expire_on_commit=False)
    answers = handle_batch(sessions, messages, transport=transport, max_bytes=64 * 1024)
    assert [a.status for a in answers] == [201] * 5, [a.body for a in answers]
    assert answers[3].body["derive_error"] == f"RuntimeError: {ERROR}"
    assert "fault_run" in answers[3].body
    assert breaker.hooked == ["ac-3"], "the optimistic pass derives without the hook"
    raws, state, faults = _stored(engine)
    assert [e for e, err in raws.items() if err] == ["ac-3"]
    assert state == "review" and len(faults) == 1
