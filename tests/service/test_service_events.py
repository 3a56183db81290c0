"""Device events: every kind, validation, idempotency, batches, device permissions."""

from __future__ import annotations

import threading
from typing import Any

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import Engine, func, select
from sqlalchemy.orm import Session

from ingest.models import RawEvent
from tests.service.linekit import build_line, event, register_bands

WHEEL_AXLES = [
    [2170, 1931, 2165, 2169, 1928, 1933, 2172, 1930],
    [2168, 1929, 2171, 2166, 1932, 1930, 2169, 1927],
    [2171, 1930, 2168, 2170, 1929, 1931, 2166, 1932],
    [2169, 1933, 2170, 2168, 1930, 1928, 2171, 1929],
]
# One valid example of every kind (from protocol.md), with the device that may send it.
EXAMPLES: list[tuple[str, dict[str, Any]]] = [
    ("A-ilk", event("e1", "train_departed", section="AB", train="2041")),
    ("B-ilk", event("e2", "train_arrived", at="2026-11-23T10:41:12Z", section="AB", train="2041")),
    ("B-ac", event("e3", "axle_count", section="AB", axles=212)),
    ("B-ir", event("e4", "ir_id", section="AB", reads=[117, 117, 119, 117, 117])),
    (
        "B-ir",
        event(
            "e5",
            "ir_pulses",
            section="AB",
            query_period_us=1000,
            reflection_window_us=200,
            reply_times_us=[262.5, 118262.0, 119263.1, 237261.9],
        ),
    ),
    (
        "B-ir",
        event(
            "e6",
            "ir_manchester",
            section="AB",
            samples_per_bit=8,
            samples=[1, 1, 1, 1, 0, 0, 0, 0, 0, 0, 0, 0, 1, 1, 1, 1],
        ),
    ),
    (
        "B-wm",
        event(
            "e7",
            "wheel_marks",
            section="AB",
            direction=1,
            baseline=[2051, 2049, 2050, 2052, 2048, 2050],
            axles=WHEEL_AXLES,
        ),
    ),
    (
        "D-mark",
        event("e8", "wheel_marks_written", car="0117", code=117, detections=["W1", "W2"] * 4),
    ),
    ("D-bench", event("e9", "measurement", car="0117", values={"brake_cylinder_fill_s": 3.1})),
    (
        "T-obu",
        event(
            "e10",
            "motion_sample",
            train="2041",
            t=1300.5,
            accel_mps2=-0.42,
            gnss_speed_mps=16.7,
            gnss_delay_s=1.8,
        ),
    ),
    ("A-cam", event("e11", "heartbeat")),
]


@pytest.mark.parametrize(("device", "body"), EXAMPLES, ids=[b["kind"] for _, b in EXAMPLES])
def test_every_kind_accepted_once(client: TestClient, device: str, body: dict[str, Any]) -> None:
    keys = build_line(client)
    register_bands(client)  # a measurement's values must name registered parameters
    first = client.post("/api/v1/events", json=body, headers=keys[device])
    assert first.status_code == 201, first.text
    assert first.json()["event_id"] == body["event_id"] and first.json()["status"] == "created"
    again = client.post("/api/v1/events", json=body, headers=keys[device])
    # the original result, marked as a replay (protocol.md)
    assert again.status_code == 200 and again.json() == {**first.json(), "status": "duplicate"}


@pytest.mark.parametrize(
    ("body", "field"),
    [
        ({"event_id": "x", "kind": "axle_count", "section": "AB", "axles": 3}, "occurred_at"),
        (event("x", "axle_count", section="AB", axles="many"), "axles"),
        (event("x", "axle_count", section="AB", axles=-1), "axles"),
        (event("x", "axle_count", at="yesterday", section="AB", axles=3), "occurred_at"),
        (event("x", "axle_count", at="2026-11-23T10:15:00", section="AB", axles=3), "occurred_at"),
        (event("x", "axle_count", at="0001-01-01T00:00:00Z", section="AB", axles=3), "occurred_at"),
        # protocol.md: times in ISO 8601 with offset; a Unix time (number or text) is refused
        (event("x", "axle_count", at=1764700000, section="AB", axles=3), "occurred_at"),
        (event("x", "axle_count", at="1764700000", section="AB", axles=3), "occurred_at"),
        (event("x", "axle_count", at=True, section="AB", axles=3), "occurred_at"),
        (event("", "axle_count", section="AB", axles=3), "event_id"),
        (event("x" * 65, "axle_count", section="AB", axles=3), "event_id"),
        (event("x", "teleport", section="AB"), "kind"),
        (event("x", "axle_count", section="AB", axles=3, extra=1), "extra"),
    ],
)
def test_invalid_events_name_the_field(
    client: TestClient, body: dict[str, Any], field: str
) -> None:
    keys = build_line(client)
    response = client.post("/api/v1/events", json=body, headers=keys["B-ac"])
    assert response.status_code == 422, response.text
    assert response.headers["content-type"] == "application/problem+json"
    problem = response.json()
    assert {"type", "title", "status", "detail", "errors"} <= problem.keys()
    assert any(field in error["loc"] for error in problem["errors"]), problem


def test_reused_event_id_with_other_body_conflicts(client: TestClient, session: Session) -> None:
    keys = build_line(client)
    body = event("ac-1", "axle_count", section="AB", axles=212)
    assert client.post("/api/v1/events", json=body, headers=keys["B-ac"]).status_code == 201
    clash = client.post("/api/v1/events", json={**body, "axles": 208}, headers=keys["B-ac"])
    assert clash.status_code == 409 and clash.headers["content-type"] == "application/problem+json"
    assert session.scalar(select(func.count()).select_from(RawEvent)) == 1
    # Another device may use the same event_id: the key is (device, event_id).
    assert client.post("/api/v1/events", json=body, headers=keys["A-ac"]).status_code == 201


def test_device_kind_and_section_rules(client: TestClient) -> None:
    keys = build_line(client)
    departed = event("d1", "train_departed", section="AB", train="1")
    assert client.post("/api/v1/events", json=departed, headers=keys["A-cam"]).status_code == 403
    assert (
        client.post("/api/v1/events", json=departed, headers={"X-Device-Key": "wrong"}).status_code
        == 401
    )
    assert client.post("/api/v1/events", json=departed).status_code == 401
    other = event("a1", "axle_count", section="BC", axles=4)
    assert client.post("/api/v1/events", json=other, headers=keys["B-ac"]).status_code == 422
    # A station-wide interlocking may name a section that starts or ends at its station only.
    assert (
        client.post(
            "/api/v1/events", json={**departed, "section": "BC"}, headers=keys["A-ilk"]
        ).status_code
        == 422
    )
    assert client.post("/api/v1/events", json=departed, headers=keys["A-ilk"]).status_code == 201


def test_batch_items_stand_alone(client: TestClient, session: Session) -> None:
    keys = build_line(client)
    good = [event(f"hb-{i}", "heartbeat") for i in range(3)]
    batch = {
        "events": [
            good[0],
            {"event_id": "bad", "kind": "heartbeat"},
            good[1],
            good[0],
            good[2],
            event("x", "train_departed", section="AB", train="1"),
        ]
    }
    response = client.post("/api/v1/events", json=batch, headers=keys["B-ac"])
    assert response.status_code == 200, response.text
    statuses = [r["status"] for r in response.json()["results"]]
    assert statuses == ["created", "rejected", "created", "duplicate", "created", "rejected"]
    assert response.json()["results"][5]["error"]["status"] == 403
    assert session.scalar(select(func.count()).select_from(RawEvent)) == 3


def test_oversized_and_empty_batches_rejected(client: TestClient, session: Session) -> None:
    keys = build_line(client)
    too_many = {"events": [event(f"hb-{i}", "heartbeat") for i in range(1001)]}
    response = client.post("/api/v1/events", json=too_many, headers=keys["B-ac"])
    assert response.status_code == 422 and "events" in str(response.json()["errors"])
    assert (
        client.post("/api/v1/events", json={"events": []}, headers=keys["B-ac"]).status_code == 422
    )
    assert session.scalar(select(func.count()).select_from(RawEvent)) == 0


def test_hostile_bodies(client: TestClient) -> None:
    keys = build_line(client)
    headers = {**keys["B-ac"], "Content-Type": "application/json"}
    assert client.post("/api/v1/events", content=b"{not json", headers=headers).status_code == 422
    deep = b"[" * 100_000 + b"]" * 100_000
    assert client.post("/api/v1/events", content=deep, headers=headers).status_code in (413, 422)
    huge = b'{"pad": "' + b"x" * (9 * 1024 * 1024) + b'"}'
    assert client.post("/api/v1/events", content=huge, headers=headers).status_code == 413
    text = {**keys["B-ac"], "Content-Type": "text/plain"}
    assert client.post("/api/v1/events", content=b"hello", headers=text).status_code == 415


def test_same_event_from_twenty_threads_is_stored_once(committed_app: Any, engine: Engine) -> None:
    with TestClient(committed_app) as client:
        keys = build_line(client)
        body = event("race-1", "axle_count", section="AB", axles=212)
        replies: list[tuple[int, Any]] = []
        barrier = threading.Barrier(20)

        def post() -> None:
            barrier.wait()
            response = client.post("/api/v1/events", json=body, headers=keys["B-ac"])
            replies.append((response.status_code, response.json()))

        threads = [threading.Thread(target=post) for _ in range(20)]
        for thread in threads:
            thread.start()
        for thread in threads:
            thread.join()
    codes = sorted(code for code, _ in replies)
    assert codes.count(201) == 1 and codes.count(200) == 19, codes
    # every answer is the one result, the 19 retries marked as such
    assert len({str({**reply, "status": None}) for _, reply in replies}) == 1
    assert sorted(reply["status"] for _, reply in replies) == ["created"] + ["duplicate"] * 19
    with engine.connect() as connection:
        stored = connection.scalar(select(func.count()).select_from(RawEvent))
    assert stored == 1


def test_wheel_marking_outcomes_are_listed(client: TestClient) -> None:
    keys = build_line(client)
    reversed_out = ["W1", "W2", "W1", "W2", "W2", "W1", "W2", "W1"]
    for event_id, detections in (("mk-1", ["W1", "W2"] * 4), ("mk-2", reversed_out)):
        body = event(event_id, "wheel_marks_written", car="0117", code=117, detections=detections)
        assert client.post("/api/v1/events", json=body, headers=keys["D-mark"]).status_code == 201
    from tests.conftest import ADMIN

    markings = client.get("/api/v1/cars/0117/wheel-markings", headers=ADMIN).json()
    assert [m["state"] for m in markings] == ["lost", "marked"]
    assert markings[1]["written"] == [True, True, True, True]


def test_a_device_clock_ahead_of_the_server_is_refused(client: TestClient) -> None:
    """A clock set to 2030 must not keep its device "alive" (issue: liveness fooled)."""
    from datetime import UTC, datetime, timedelta

    from tests.service.linekit import build_line

    keys = build_line(client)
    now = datetime.now(UTC)
    for ahead, status in ((timedelta(days=1500), 422), (timedelta(seconds=400), 422)):
        body = {
            "event_id": f"ahead-{ahead.total_seconds():.0f}",
            "occurred_at": (now + ahead).isoformat(),
            "kind": "axle_count",
            "section": "AB",
            "axles": 4,
        }
        answer = client.post("/api/v1/events", json=body, headers=keys["A-ac"])
        assert answer.status_code == status, answer.text
        assert "ahead of the server's clock" in answer.json()["detail"]
    near = {"event_id": "near", "occurred_at": (now + timedelta(seconds=60)).isoformat(),
            "kind": "heartbeat"}  # fmt: skip
    assert client.post("/api/v1/events", json=near, headers=keys["A-ac"]).status_code == 201
    from tests.conftest import ADMIN

    device = client.get("/api/v1/devices/A-ac", headers=ADMIN).json()
    seen = datetime.fromisoformat(device["last_seen_at"])
    assert seen < now + timedelta(seconds=301)


def test_a_retry_in_another_spelling_is_the_same_event(client: TestClient) -> None:
    """protocol.md: Z and +00:00 are the same instant; key order and number spelling too."""
    from tests.service.linekit import build_line

    keys = build_line(client)
    body = {"event_id": "spell-1", "occurred_at": "2026-11-23T10:01:05Z", "kind": "axle_count",
            "section": "AB", "axles": 10}  # fmt: skip
    first = client.post("/api/v1/events", json=body, headers=keys["A-ac"])
    assert first.status_code == 201 and first.json()["status"] == "created"
    for retry in (
        {**body, "occurred_at": "2026-11-23T10:01:05+00:00"},
        {**body, "occurred_at": "2026-11-23T12:01:05.000+02:00"},
        {**body, "axles": 10.0},
    ):
        again = client.post("/api/v1/events", json=retry, headers=keys["A-ac"])
        assert again.status_code == 200, (retry, again.text)
        assert again.json()["status"] == "duplicate"
    other = client.post("/api/v1/events", json={**body, "axles": 11}, headers=keys["A-ac"])
    assert other.status_code == 409


def test_numbers_of_the_wrong_json_type_are_refused(client: TestClient) -> None:
    """``"axles": true`` was counted as 1 axle and ``"12"`` as 12 (found by the independent
    trial); a count, a code or a value must come as a JSON number."""
    from datetime import UTC, datetime

    from tests.service.linekit import build_line

    keys = build_line(client)
    now = datetime.now(UTC).isoformat()
    for n, axles in enumerate((True, "12", 12.5, None)):
        body = {"event_id": f"type-{n}", "occurred_at": now, "kind": "axle_count",
                "section": "AB", "axles": axles}  # fmt: skip
        answer = client.post("/api/v1/events", json=body, headers=keys["A-ac"])
        assert answer.status_code == 422, (axles, answer.text)
        assert answer.json()["errors"][0]["loc"][-1] == "axles"
    good = {"event_id": "type-ok", "occurred_at": now, "kind": "axle_count", "section": "AB",
            "axles": 12}  # fmt: skip
    assert client.post("/api/v1/events", json=good, headers=keys["A-ac"]).status_code == 201


@pytest.mark.parametrize("sample", [True, False, "1", 2, -1, 0.5])
def test_manchester_samples_are_the_numbers_0_and_1(client: TestClient, sample: object) -> None:
    """``"samples": [true, ...]`` was read as 1 (an independent trial): a sample is the JSON
    number 0 or 1 (protocol.md: "list of 0/1"), and anything else is refused, naming the field."""
    keys = build_line(client)
    samples = [1, 1, 1, 1, 0, 0, 0, 0]
    body = event("m-bad", "ir_manchester", section="AB", samples_per_bit=4,
                 samples=[*samples, sample])  # fmt: skip
    answer = client.post("/api/v1/events", json=body, headers=keys["B-ir"])
    assert answer.status_code == 422, (sample, answer.text)
    assert answer.headers["content-type"] == "application/problem+json"
    assert "samples" in answer.json()["errors"][0]["loc"], answer.json()
    good = event("m-ok", "ir_manchester", section="AB", samples_per_bit=4,
                 samples=[*samples, 1.0, 0])  # fmt: skip
    assert client.post("/api/v1/events", json=good, headers=keys["B-ir"]).status_code == 201


def test_a_key_sent_twice_in_one_object_is_refused(client: TestClient) -> None:
    """``"axles": 1, "axles": 500`` stored 500 (found by the independent trial): which value the
    device meant is unknown, so the event is refused and nothing stored."""
    from tests.service.linekit import build_line

    keys = build_line(client)
    raw = ('{"event_id": "dup-key", "occurred_at": "2026-11-23T10:01:05Z", "kind": "axle_count",'
           ' "section": "AB", "axles": 1, "axles": 500}')  # fmt: skip
    headers = {**keys["A-ac"], "Content-Type": "application/json"}
    answer = client.post("/api/v1/events", content=raw, headers=headers)
    assert answer.status_code == 422, answer.text
    assert "repeats the key 'axles'" in answer.json()["detail"]
    utf16 = '{"kind": "heartbeat"}'.encode("utf-16")
    answer = client.post("/api/v1/events", content=utf16, headers=headers)
    assert answer.status_code == 422 and "UTF-8" in answer.json()["detail"], answer.text


def test_a_lone_surrogate_escape_is_refused_and_a_pair_is_kept(client: TestClient) -> None:
    """``"\\ud800"`` alone is no character: it cannot be hashed or stored as UTF-8, and the
    device got a 500 (found while speeding up batches). It is refused, single and in a batch,
    naming the problem; an escaped pair (an emoji) is one character and is kept."""
    from tests.service.linekit import build_line

    keys = build_line(client)
    headers = {**keys["A-ilk"], "Content-Type": "application/json"}
    lone = ('{"event_id": "lone", "occurred_at": "2026-11-23T10:01:05Z", "kind":'
            ' "train_departed", "section": "AB", "train": "2001\\ud800"}')  # fmt: skip
    answer = client.post("/api/v1/events", content=lone, headers=headers)
    assert answer.status_code == 422, answer.text
    assert answer.headers["content-type"].startswith("application/problem+json")
    assert "surrogate" in answer.json()["detail"]
    # In a parameter name (a dict key, which pydantic passes through): this was the 500.
    reading = ('{"event_id": "lone-key", "occurred_at": "2026-11-23T10:01:05Z", "kind":'
               ' "measurement", "car": "0117", "values": {"P30\\udc00": 1.5}}')  # fmt: skip
    bench = {**keys["D-bench"], "Content-Type": "application/json"}
    answer = client.post("/api/v1/events", content=reading, headers=bench)
    assert answer.status_code == 422 and "surrogate" in answer.json()["detail"], answer.text
    batch = '{"events": [' + lone + "]}"
    answer = client.post("/api/v1/events", content=batch, headers=headers)
    assert answer.status_code == 422, answer.text
    pair = ('{"event_id": "pair", "occurred_at": "2026-11-23T10:01:05Z", "kind":'
            ' "train_departed", "section": "AB", "train": "2001\\ud83d\\ude82"}')  # fmt: skip
    answer = client.post("/api/v1/events", content=pair, headers=headers)
    assert answer.status_code == 201, answer.text
    assert answer.json()["event_id"] == "pair"
