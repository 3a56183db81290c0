"""Snapshot detection runs before the event is stored, never inside its transaction.

The derivation of a ``tail_snapshot`` holds the section's lock; detection on a 1080p image
takes a tenth of a second of CPU, so done there it holds up every other event of the section.
It is prepared in a worker thread before the event is stored, and the derivation uses it; the
stored verdict is the one replay computes from the image.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from fastapi.testclient import TestClient
from PIL import Image
from sqlalchemy import select
from sqlalchemy.orm import Session

import ingest.handlers
import ingest.service
import tail_check
from ingest.models import Snapshot
from ingest.snapshots import load_bgr
from service.clearance import tail
from service.replay import replay
from tests.service.linekit import build_line
from tests.service.test_service_snapshots import encoded, upload


@pytest.fixture(autouse=True)
def _nothing_prepared() -> None:
    """Each test starts with no prepared detection: they are kept per (camera, image) in
    the process, and an earlier test uploading the same image from the same camera in
    this worker may have left one that this test's derivation would then use."""
    with tail._prepared_lock:
        tail._prepared.clear()


@pytest.fixture
def detections(monkeypatch: pytest.MonkeyPatch) -> list[bool]:
    """One entry per detection: whether it ran while the event was being stored."""
    calls: list[bool] = []
    storing = [False]
    detect, store_event = tail_check.detect, ingest.service.store_event
    detect_snapshot = tail_check.detect_snapshot  # JPEGs: decoded at reduced size

    def counted(*args: Any, **kwargs: Any) -> Any:
        calls.append(storing[0])
        return detect(*args, **kwargs)

    def counted_snapshot(*args: Any, **kwargs: Any) -> Any:
        calls.append(storing[0])
        return detect_snapshot(*args, **kwargs)

    def storing_event(*args: Any, **kwargs: Any) -> Any:
        storing[0] = True
        try:
            return store_event(*args, **kwargs)
        finally:
            storing[0] = False

    monkeypatch.setattr(tail_check, "detect", counted)
    monkeypatch.setattr(tail_check, "detect_snapshot", counted_snapshot)
    monkeypatch.setattr(ingest.service, "store_event", storing_event)
    return calls


def test_detection_runs_once_before_the_event_is_stored(
    client: TestClient, session: Session, detections: list[bool]
) -> None:
    keys = build_line(client)
    response = upload(client, keys["B-cam"], encoded(".jpg"), event_id="prep-1")
    assert response.status_code == 201, response.text  # type: ignore[attr-defined]
    assert response.json()["verdict"] in ("present", "absent", "uncertain")  # type: ignore[attr-defined]
    assert detections == [False]


def test_a_failing_preparation_leaves_the_work_to_the_derivation(
    client: TestClient, session: Session, detections: list[bool], monkeypatch: pytest.MonkeyPatch
) -> None:
    keys = build_line(client)

    def broken(*_: Any) -> None:
        raise RuntimeError("no profile today")

    monkeypatch.setattr(tail, "camera_profile", lambda device_id: None)
    monkeypatch.setitem(ingest.handlers.PREPARERS, "tail_snapshot", broken)
    response = upload(client, keys["B-cam"], encoded(".jpg"), event_id="prep-2")
    assert response.status_code == 201, response.text  # type: ignore[attr-defined]
    assert response.json()["verdict"] is not None  # type: ignore[attr-defined]
    assert detections == [True]  # computed by the derivation itself


def test_the_prepared_verdict_is_the_one_replay_computes(
    client: TestClient, session: Session
) -> None:
    keys = build_line(client)
    for n in range(3):
        response = upload(
            client, keys["B-cam"], encoded(".jpg", width=320 + 16 * n), event_id=f"r{n}"
        )
        assert response.status_code == 201, response.text  # type: ignore[attr-defined]
    live = [
        (s.id, s.verdict, s.score) for s in session.scalars(select(Snapshot).order_by(Snapshot.id))
    ]
    replay(session)
    again = [
        (s.id, s.verdict, s.score) for s in session.scalars(select(Snapshot).order_by(Snapshot.id))
    ]
    assert len(live) == 3 and again == live


@pytest.mark.parametrize("mode", ["RGB", "L", "RGBA", "P"])
def test_load_bgr_is_the_reversed_rgb_conversion(tmp_path: Path, mode: str) -> None:
    """The faster decoding gives exactly the array of converting to RGB and reversing the
    channels (every stored verdict was computed from that array)."""
    rng = np.random.default_rng(7)
    pixels = rng.integers(0, 256, (48, 64, 3), dtype=np.uint8)
    image = Image.fromarray(pixels).convert(mode)
    path = tmp_path / "image.png"
    image.save(path)
    with Image.open(path) as reopened:
        expected = np.ascontiguousarray(np.asarray(reopened.convert("RGB"))[:, :, ::-1])
    got = load_bgr(path)
    assert got.dtype == np.uint8 and got.flags.c_contiguous
    assert np.array_equal(got, expected)
