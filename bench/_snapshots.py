"""Snapshot part of the ingest benchmark: upload → verdict stored, 10 cameras at once."""

from __future__ import annotations

import statistics
import threading
import time
from concurrent.futures import ThreadPoolExecutor

import cv2
import httpx

from bench._load import Round, drive
from bench._server import admin
from tail_check.synth import render_snapshot

CAMERAS = 10
ROUNDS = 5
SIZE = (1920, 1080)
BACKGROUND_CONNECTIONS = 8


def _cameras(url: str) -> list[str]:
    keys = []
    with httpx.Client(base_url=f"{url}/api/v1", headers=admin(), timeout=30) as client:
        for i in range(CAMERAS):
            body = {"id": f"cam-{i}", "station": "B", "section": "AB", "kind": "camera"}
            response = client.post("/devices", json=body)
            response.raise_for_status()
            keys.append(response.json()["key"])
    return keys


def _jpeg(seed: int) -> bytes:
    image, _ = render_snapshot(seed, disc=seed % 2 == 0, condition="day", size=SIZE)
    ok, data = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, 90])
    assert ok
    return data.tobytes()


def _upload(url: str, key: str, event_id: str, image: bytes, start: threading.Barrier) -> float:
    form = {"event_id": event_id, "occurred_at": "2026-11-23T10:00:00Z", "section": "AB"}
    with httpx.Client(base_url=f"{url}/api/v1", timeout=60) as client:
        start.wait()
        began = time.perf_counter()
        response = client.post(
            "/snapshots",
            headers={"X-Device-Key": key},
            data=form,
            files={"image": ("tail.jpg", image, "image/jpeg")},
        )
        elapsed = time.perf_counter() - began
    if response.status_code != 201 or response.json().get("verdict") is None:
        raise RuntimeError(f"snapshot not stored with a verdict: {response.status_code}")
    return elapsed


def snapshot_latency(url: str, *, background_keys: list[str]) -> None:
    """Print upload → verdict-stored p50/p99 and the single-event latency meanwhile."""
    keys = _cameras(url)
    images = [[_jpeg(100 * r + c) for c in range(CAMERAS)] for r in range(ROUNDS)]
    latencies: list[float] = []
    background: list[Round] = []
    stop_after = 3.0 * ROUNDS
    events = threading.Thread(
        target=lambda: background.append(
            drive(url, background_keys, "snapbg", batch=0,
                  connections=BACKGROUND_CONNECTIONS, seconds=stop_after)
        )
    )  # fmt: skip
    events.start()
    with ThreadPoolExecutor(CAMERAS) as pool:
        for r in range(ROUNDS):
            start = threading.Barrier(CAMERAS)
            jobs = [
                pool.submit(_upload, url, keys[c], f"snap-{r}-{c}", images[r][c], start)
                for c in range(CAMERAS)
            ]
            latencies += [job.result() for job in jobs]
            time.sleep(1.0)
    events.join()
    q = statistics.quantiles(latencies, n=100)
    print(
        f"snapshots: {len(latencies)} uploads of {SIZE[0]}×{SIZE[1]} JPEGs, {CAMERAS} cameras"
        f" at once: upload → verdict stored p50 {q[49] * 1000:.0f} ms, p99 {q[98] * 1000:.0f} ms"
    )
    if background:
        bg = background[0]
        print(
            f"  single events meanwhile ({BACKGROUND_CONNECTIONS} connections):"
            f" {bg.requests / bg.seconds:,.0f}/s, p50 {bg.p50_ms:.1f} ms, p99 {bg.p99_ms:.1f} ms"
        )
