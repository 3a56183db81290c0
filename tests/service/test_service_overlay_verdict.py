"""The overlay the dispatcher sees draws the stored verdict, never a new detection.

``GET /snapshots/{id}/overlay`` ran the hand-tuned detector again and drew its answer: on a
snapshot the learned verifier had held ``uncertain`` (a hand wheel), a green ``PRESENT``
banner.
"""

from __future__ import annotations

from datetime import timedelta

import cv2
import numpy as np
import pytest
from fastapi.testclient import TestClient
from sqlalchemy import update
from sqlalchemy.orm import Session

from tests.conftest import ADMIN
from tests.service.clock import ServerClock, server_clock  # noqa: F401 (fixture)
from tests.service.linekit import build_line
from tests.service.scenario import T0, Line, jpeg

ARRIVED = T0 + timedelta(minutes=20)
VERDICT_BGR = {"present": (60, 200, 60), "uncertain": (0, 190, 255), "absent": (40, 40, 230)}
"""The overlay's verdict colours (tail_check.overlay)."""


def banner_verdict(png: bytes) -> str:
    """The verdict whose colour the overlay's banner text is drawn in (most pixels near it)."""
    image = cv2.imdecode(np.frombuffer(png, np.uint8), cv2.IMREAD_COLOR)
    assert image is not None, "the overlay is a PNG"
    banner = image[: max(12, image.shape[0] // 12)].astype(np.int32)
    near = {
        verdict: int((np.abs(banner - np.array(bgr)).sum(axis=2) < 60).sum())
        for verdict, bgr in VERDICT_BGR.items()
    }
    return max(near, key=lambda verdict: near[verdict])


def overlay_of(client: TestClient, snapshot: int) -> str:
    answer = client.get(f"/api/v1/snapshots/{snapshot}/overlay", headers=ADMIN)
    assert answer.status_code == 200 and answer.headers["content-type"] == "image/png"
    return banner_verdict(answer.content)


@pytest.mark.parametrize(("ext", "mime"), [(".jpg", "image/jpeg"), (".png", "image/png")])
def test_a_hand_wheel_held_uncertain_is_shown_uncertain(
    client: TestClient, ext: str, mime: str
) -> None:
    from tail_check import detect
    from tail_check.dataset import scenes

    sample = next(scenes("A", "heldout", 1, offset=44))
    assert sample.kind == "hand_wheel" and detect(sample.image).verdict == "present"
    ok, data = cv2.imencode(ext, sample.image)
    assert ok
    keys = build_line(client)
    form = {"event_id": "w1", "occurred_at": "2026-11-23T10:41:00Z", "section": "AB"}
    files = {"image": (f"tail{ext}", data.tobytes(), mime)}
    stored = client.post("/api/v1/snapshots", data=form, files=files, headers=keys["B-cam"])
    assert stored.status_code == 201 and stored.json()["verdict"] == "uncertain", stored.text
    assert overlay_of(client, stored.json()["snapshot"]) == "uncertain"


def test_an_arrival_judged_against_its_departure_is_drawn_with_the_stored_verdict(
    line: Line, client: TestClient
) -> None:
    """A two-camera verdict is stored with its arrival image's boxes inside (no search
    region of its own): the overlay draws the stored verdict and the arrival's boxes."""
    line.heartbeat_all(T0 - timedelta(seconds=20))
    departure = line.snapshot("A-cam", T0 - timedelta(seconds=10), jpeg(disc=True, seed=2))
    line.depart(T0)
    line.heartbeat_all(ARRIVED - timedelta(seconds=30))
    arrival = line.snapshot("B-cam", ARRIVED - timedelta(seconds=5), jpeg(disc=False, seed=3))
    meta = client.get(f"/api/v1/snapshots/{arrival['snapshot']}/meta", headers=ADMIN).json()
    assert meta["detection"]["reference_snapshot"] == departure["snapshot"], meta
    assert meta["detection"]["lost_rear"] is True
    assert overlay_of(client, arrival["snapshot"]) == arrival["verdict"] == "absent"
    assert overlay_of(client, departure["snapshot"]) == departure["verdict"] == "present"


def test_a_snapshot_without_a_stored_verdict_is_judged_as_the_service_judges(
    client: TestClient, session: Session
) -> None:
    """A row without its verdict (a column left empty by an older version) is drawn with
    the service's confirmed verdict, not the hand-tuned detector's ``present``."""
    from ingest.models import Snapshot
    from tail_check.dataset import scenes

    sample = next(scenes("A", "heldout", 1, offset=44))  # the hand wheel
    ok, data = cv2.imencode(".png", sample.image)
    assert ok
    keys = build_line(client)
    form = {"event_id": "w2", "occurred_at": "2026-11-23T10:41:00Z", "section": "AB"}
    files = {"image": ("tail.png", data.tobytes(), "image/png")}
    stored = client.post("/api/v1/snapshots", data=form, files=files, headers=keys["B-cam"])
    assert stored.status_code == 201, stored.text
    session.execute(
        update(Snapshot).where(Snapshot.id == stored.json()["snapshot"]).values(detection=None)
    )
    session.commit()
    assert overlay_of(client, stored.json()["snapshot"]) == "uncertain"
