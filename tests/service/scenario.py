"""A train's passage through section AB, posted as the devices would post it."""

from __future__ import annotations

from dataclasses import dataclass
from datetime import UTC, datetime, timedelta
from typing import Any

import cv2
from fastapi.testclient import TestClient

from ingest.liveness import LAST_SEEN_GRANULARITY, heartbeat_limit
from tail_check.synth import render_snapshot
from tests.conftest import ADMIN
from tests.service.clock import ServerClock
from tests.service.linekit import build_line

T0 = datetime(2026, 11, 23, 10, 0, tzinfo=UTC)


def iso(at: datetime) -> str:
    return at.isoformat().replace("+00:00", "Z")


def jpeg(*, disc: bool, condition: str = "day", seed: int = 7, weak: bool = False) -> bytes:
    image, _ = render_snapshot(
        seed, disc=disc, condition=condition, weak_disc=weak, distractors=(), occlusion=0.0
    )
    ok, data = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, 92])
    assert ok
    return data.tobytes()


def alive_step() -> timedelta:
    """The longest step between heartbeats that keeps a device provably alive: a device is
    silent when nothing of it was received for *longer* than the heartbeat period
    (``DEPOT_HEARTBEAT_S``, 60 s), and the stored ``last_seen_at`` may lag the last receipt
    by up to ``LAST_SEEN_GRANULARITY`` (5 s): heard each 55 s, even that stored value is never
    more than 60 s old. (``test_a_gap_counts_only_past_the_heartbeat_period`` shows 55 s
    alive.) A smaller step proves nothing more and costs a post per device per step: heartbeats
    are most of a journey's requests, and they cannot share a batch, which comes from one
    device and is received at one instant (``ingest.liveness.touched_at_end``)."""
    step = heartbeat_limit() - LAST_SEEN_GRANULARITY
    assert step > timedelta(0), step
    return step


def alive_times(start: datetime, end: datetime) -> list[datetime]:
    """``start``, each :func:`alive_step` after it, and ``end``: no gap in [start, end] is
    longer than the step (the window's end is heard too, not up to a step before it)."""
    step, times, at = alive_step(), [], start
    while at < end:
        times.append(at)
        at += step
    return [*times, end] if end >= start else times


@dataclass
class Line:
    client: TestClient
    keys: dict[str, dict[str, str]]
    serial: int = 0
    # With a clock, each event reaches the server at its device time, or at ``received``.
    clock: ServerClock | None = None

    @classmethod
    def clocked(cls, client: TestClient, clock: ServerClock, **line: Any) -> Line:
        """A line whose events reach the server at their device times (or ``received``),
        registered an hour before :data:`T0`: a device owes heartbeats only once registered
        (``ingest.liveness.silent_during``), so it must exist before the trains run."""
        clock.set(T0 - timedelta(hours=1))
        return cls(client, build_line(client, **line), clock=clock)

    def keep_alive(self, start: datetime, end: datetime, *, except_: tuple[str, ...] = ()) -> None:
        """Every device but ``except_`` heartbeats from ``start`` to ``end``, as a live line
        does while a train passes: each :func:`alive_step` and at ``end`` itself, so that the
        line is heard throughout [start, end] whatever the window's length."""
        for at in alive_times(start, end):
            self.heartbeat_all(at, except_=except_)

    def _arrives(self, at: datetime, received: datetime | None) -> None:
        if self.clock is not None:
            self.clock.set(received or at)

    def post(
        self, device: str, kind: str, at: datetime, received: datetime | None = None, **fields: Any
    ) -> dict[str, Any]:
        self.serial += 1
        self._arrives(at, received)
        body = {
            "event_id": f"{device}-{self.serial}",
            "occurred_at": iso(at),
            "kind": kind,
            **fields,
        }
        response = self.client.post("/api/v1/events", json=body, headers=self.keys[device])
        assert response.status_code == 201, response.text
        result: dict[str, Any] = response.json()
        return result

    def heartbeat_all(self, at: datetime, *, except_: tuple[str, ...] = ()) -> None:
        for device in self.keys:
            if device not in except_:
                self.post(device, "heartbeat", at)

    def snapshot(
        self, device: str, at: datetime, data: bytes, received: datetime | None = None
    ) -> dict[str, Any]:
        self.serial += 1
        self._arrives(at, received)
        form = {"event_id": f"{device}-{self.serial}", "occurred_at": iso(at), "section": "AB"}
        response = self.client.post(
            "/api/v1/snapshots",
            data=form,
            files={"image": ("t.jpg", data, "image/jpeg")},
            headers=self.keys[device],
        )
        assert response.status_code == 201, response.text
        result: dict[str, Any] = response.json()
        return result

    def read(self, end: str, cars: list[int], at: datetime) -> None:
        """IR reader of one end of AB reads these car numbers (decoded on the device)."""
        for i, car in enumerate(cars):
            self.post(
                f"{end}-ir", "ir_id", at + timedelta(seconds=i), section="AB", reads=[car] * 5
            )

    def section(self, ident: str = "AB") -> dict[str, Any]:
        result: dict[str, Any] = self.client.get(f"/api/v1/sections/{ident}", headers=ADMIN).json()
        return result

    def depart(self, at: datetime = T0, train: str = "2041") -> int:
        result = self.post("A-ilk", "train_departed", at, section="AB", train=train)
        run: int = result["run"]
        return run

    def arrive(self, at: datetime, train: str = "2041") -> dict[str, Any]:
        return self.post("B-ilk", "train_arrived", at, section="AB", train=train)
