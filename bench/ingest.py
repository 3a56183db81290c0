"""Ingest benchmark: a real uvicorn (2 workers) on 127.0.0.1 against PostgreSQL, clients in other
processes. Prints single-event throughput with p50/p99 latency (acknowledged after commit) and
batched throughput. Bounded in count and time."""

from __future__ import annotations

import statistics
import time
from concurrent.futures import ProcessPoolExecutor

import httpx

from bench._server import admin, bench_database, serve

DEVICES = 50
SINGLE_PER_DEVICE = 100
BATCHES_PER_DEVICE = 4
BATCH = 500


def setup(url: str) -> list[str]:
    with httpx.Client(base_url=f"{url}/api/v1", headers=admin(), timeout=30) as client:
        client.post("/stations", json={"id": "A", "name": "A"}).raise_for_status()
        client.post("/stations", json={"id": "B", "name": "B"}).raise_for_status()
        client.post(
            "/sections", json={"id": "AB", "from_station": "A", "to_station": "B"}
        ).raise_for_status()
        keys = []
        for i in range(DEVICES):
            body = {"id": f"ac-{i}", "station": "B", "section": "AB", "kind": "axle_counter"}
            response = client.post("/devices", json=body)
            response.raise_for_status()
            keys.append(response.json()["key"])
    return keys


def post_singles(args: tuple[str, str, int]) -> list[float]:
    url, key, index = args
    latencies = []
    with httpx.Client(
        base_url=f"{url}/api/v1", headers={"X-Device-Key": key}, timeout=30
    ) as client:
        for n in range(SINGLE_PER_DEVICE):
            body = {
                "event_id": f"s-{index}-{n}",
                "occurred_at": "2026-11-23T10:00:00Z",
                "kind": "axle_count",
                "section": "AB",
                "axles": 4 * (n % 50),
            }
            start = time.perf_counter()
            response = client.post("/events", json=body)
            latencies.append(time.perf_counter() - start)
            if response.status_code != 201:
                raise RuntimeError(f"{response.status_code} {response.text}")
    return latencies


def post_batches(args: tuple[str, str, int]) -> int:
    url, key, index = args
    sent = 0
    with httpx.Client(
        base_url=f"{url}/api/v1", headers={"X-Device-Key": key}, timeout=120
    ) as client:
        for b in range(BATCHES_PER_DEVICE):
            events = [
                {
                    "event_id": f"b-{index}-{b}-{n}",
                    "occurred_at": "2026-11-23T10:00:00Z",
                    "kind": "heartbeat",
                }
                for n in range(BATCH)
            ]
            response = client.post("/events", json={"events": events})
            response.raise_for_status()
            results = response.json()["results"]
            sent += sum(r["status"] == "created" for r in results)
    return sent


def main() -> None:
    url_db = bench_database("depot_bench_ingest")
    print(f"database: {url_db.split('@')[-1]}")
    with serve(url_db, workers=2) as url:
        keys = setup(url)
        jobs = [(url, key, i) for i, key in enumerate(keys)]
        with ProcessPoolExecutor(max_workers=8) as pool:
            start = time.perf_counter()
            latencies = [
                lat for chunk in pool.map(post_singles, jobs, chunksize=7) for lat in chunk
            ]
            elapsed = time.perf_counter() - start
            q = statistics.quantiles(latencies, n=100)
            print(
                f"single events: {len(latencies)} in {elapsed:.1f} s"
                f" = {len(latencies) / elapsed:,.0f}/s; latency p50 {q[49] * 1000:.1f} ms,"
                f" p99 {q[98] * 1000:.1f} ms (8 client processes)"
            )
            batch_jobs = jobs[:10]
            start = time.perf_counter()
            created = sum(pool.map(post_batches, batch_jobs))
            elapsed = time.perf_counter() - start
            print(
                f"batched events: {created} in {elapsed:.1f} s = {created / elapsed:,.0f}/s"
                f" (batches of {BATCH})"
            )


if __name__ == "__main__":
    main()
