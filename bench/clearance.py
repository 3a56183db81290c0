"""Clearance benchmark: decision latency from ``train_arrived`` to the section state readable
through the API (p50/p99, all evidence present), and ``/review`` render time with 50 sections and
1,000 runs. A real uvicorn (2 workers) on 127.0.0.1, PostgreSQL when available."""

from __future__ import annotations

import statistics
import time
from datetime import UTC, datetime, timedelta
from typing import Any

import cv2
import httpx

from bench._server import admin, bench_database, serve
from tail_check.synth import render_snapshot

SECTIONS = 50
RUNS_PER_SECTION = 20
T0 = datetime(2026, 11, 1, tzinfo=UTC)


def setup(client: httpx.Client) -> dict[str, dict[str, str]]:
    keys: dict[str, dict[str, str]] = {}
    for i in range(SECTIONS + 1):
        client.post("/stations", json={"id": f"S{i}", "name": f"Station {i}"}).raise_for_status()
    for i in range(SECTIONS):
        section = {"id": f"X{i}", "from_station": f"S{i}", "to_station": f"S{i + 1}"}
        client.post("/sections", json=section).raise_for_status()
        for station, end in ((f"S{i}", "dep"), (f"S{i + 1}", "arr")):
            for kind, short in (("interlocking", "ilk"), ("camera", "cam"), ("axle_counter", "ac")):
                ident = f"X{i}-{end}-{short}"
                body = {"id": ident, "station": station, "section": f"X{i}", "kind": kind}
                response = client.post("/devices", json=body)
                response.raise_for_status()
                keys[ident] = {"X-Device-Key": response.json()["key"]}
    return keys


def jpeg(seed: int) -> bytes:
    image, _ = render_snapshot(seed, disc=True, condition="day", distractors=(), occlusion=0.0)
    return cv2.imencode(".jpg", image)[1].tobytes()


def run(
    client: httpx.Client, keys: dict[str, dict[str, str]], section: int, n: int, image: bytes | None
) -> float | None:
    """One run; returns the decision latency when all evidence is present."""
    start = T0 + timedelta(hours=n, minutes=section)

    def at(dt: float) -> str:
        return (start + timedelta(seconds=dt)).isoformat()

    x = f"X{section}"
    events: list[tuple[str, dict[str, Any], int]] = [
        ("dep-ac", {"kind": "axle_count", "section": x, "axles": 40}, -30),
        ("dep-ilk", {"kind": "train_departed", "section": x, "train": f"{n}"}, 0),
    ]
    events += [
        (f"{end}-{d}", {"kind": "heartbeat"}, t)
        for end, t in (("dep", -40), ("arr", 1170))
        for d in ("cam", "ac")
    ]
    events += [("arr-ac", {"kind": "axle_count", "section": x, "axles": 40}, 1180)]
    for device, body, dt in sorted(events, key=lambda e: e[2]):
        event = {"event_id": f"{n}-{dt}-{device}", "occurred_at": at(dt), **body}
        response = client.post("/events", json=event, headers=keys[f"{x}-{device}"])
        if response.status_code not in (200, 201):
            raise RuntimeError(f"{device} {event}: {response.status_code} {response.text}")
    if image is not None:
        form = {"event_id": f"{n}-snap", "occurred_at": at(1190), "section": x}
        client.post(
            "/snapshots",
            data=form,
            files={"image": ("t.jpg", image, "image/jpeg")},
            headers=keys[f"{x}-arr-cam"],
        ).raise_for_status()
    arrived = {
        "event_id": f"{n}-arr",
        "occurred_at": at(1200),
        "kind": "train_arrived",
        "section": x,
        "train": f"{n}",
    }
    t = time.perf_counter()
    client.post("/events", json=arrived, headers=keys[f"{x}-arr-ilk"]).raise_for_status()
    answer = client.get(f"/sections/{x}", headers=admin()).json()
    latency = time.perf_counter() - t
    state = answer["state"]
    if image is not None and state != "free":
        print(f"  section {x} is {state}: {answer['run']['decision']['reasons']}")
    return latency if image is not None and state == "free" else None


def main() -> None:
    url_db = bench_database("depot_bench_clearance")
    print(f"database: {url_db.split('@')[-1]}")
    with (
        serve(url_db, workers=2) as url,
        httpx.Client(base_url=f"{url}/api/v1", headers=admin(), timeout=60) as setup_client,
        httpx.Client(base_url=f"{url}/api/v1", timeout=60) as client,
    ):
        keys = setup(setup_client)
        image = jpeg(1)
        latencies = []
        started = time.perf_counter()
        for n in range(RUNS_PER_SECTION):
            for section in range(SECTIONS):
                latency = run(client, keys, section, n, image)
                if latency is not None:
                    latencies.append(latency)
        print(
            f"loaded {SECTIONS} sections, {SECTIONS * RUNS_PER_SECTION} runs in"
            f" {time.perf_counter() - started:.0f} s"
        )
        q = statistics.quantiles(latencies, n=100)
        print(
            f"decision latency (train_arrived POST + section GET, all evidence present):"
            f" p50 {q[49] * 1000:.1f} ms, p99 {q[98] * 1000:.1f} ms over {len(latencies)} runs"
        )
        with httpx.Client(base_url=url, timeout=60) as browser:
            browser.post("/review/login", data={"token": admin()["Authorization"][7:]})
            renders = []
            for _ in range(30):
                t = time.perf_counter()
                browser.get("/review").raise_for_status()
                renders.append(time.perf_counter() - t)
            q = statistics.quantiles(renders, n=100)
            print(
                f"/review render ({SECTIONS} sections, {SECTIONS * RUNS_PER_SECTION} runs):"
                f" p50 {q[49] * 1000:.1f} ms, p99 {q[98] * 1000:.1f} ms"
            )


if __name__ == "__main__":
    main()
