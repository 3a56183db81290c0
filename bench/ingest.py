"""Ingest benchmark: depot against the reference floor, side by side in one run.

Three servers, each uvicorn with 2 workers on 127.0.0.1, each on its own PostgreSQL database:
the floor (``bench/floor_app.py``: key check, pydantic, one ``INSERT … ON CONFLICT DO NOTHING
RETURNING`` plus commit per request, one multi-row insert per batch), depot with group commit
(the default) and depot with ``DEPOT_GROUP_COMMIT_MS=0``. The same load generator drives them in
alternating rounds (depot, like the floor, without a log line per request:
``DEPOT_ACCESS_LOG=false``): ``wrk`` (install with ``apt-get install -y wrk``) with a Lua script, 32
connections for single ``axle_count`` events (and single ``heartbeat`` events, which no feature
derives from: the price of ingest itself), 8 connections for batches of 500 heartbeats; the
Python client in ``bench/_load.py`` when ``wrk`` is absent. Printed: events/s, p50, p99 per
server and the ratio depot / floor (summed over the rounds). Then the snapshot path on its own:
10 cameras upload a 1080p JPEG at once, upload → verdict stored (the answer is sent after the
commit that stores the verdict), p50/p99, while single events keep flowing.

Then single axle counts by connection count (2 to 32), floor and depot side by side: where the
issue's p99 of 50 ms is reachable on the machine at all.

Run: ``.venv/bin/python -m bench.ingest`` (about 3 minutes; ``BENCH_ROUNDS`` and
``BENCH_SECONDS`` shorten it). ``--only batches`` runs the batch comparison alone (the floor and
depot with group commit, which a batch does not go through anyway): about a minute, for
measuring a change to the batch path.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from collections.abc import Iterator
from contextlib import ExitStack, contextmanager
from pathlib import Path

import httpx

from bench import floor_app
from bench._load import Round, drive, have_wrk
from bench._server import admin, bench_database, free_port, running, serve
from bench._snapshots import snapshot_latency

DEVICES = 32
BATCH = 500
ROUNDS = int(os.environ.get("BENCH_ROUNDS", "3"))
SECONDS = float(os.environ.get("BENCH_SECONDS", "6"))
SINGLE_CONNECTIONS = 32
BATCH_CONNECTIONS = 8
# The tail target, and the connection counts the sweep tries it at.
P99_TARGET_MS = 50.0
SWEEP_CONNECTIONS = (2, 4, 8, 16, 32)  # wrk needs a connection per thread (2)


def setup_depot(url: str) -> list[str]:
    """Two stations, section AB, ``DEVICES`` axle counters at B; returns their keys."""
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


@contextmanager
def serve_floor(database_url: str, keys: list[str]) -> Iterator[str]:
    floor_app.prepare(database_url, {f"ac-{i}": key for i, key in enumerate(keys)})
    port = free_port()
    uvicorn = str(Path(sys.executable).parent / "uvicorn")
    command = [uvicorn, "bench.floor_app:create_app", "--factory", "--workers", "2",
               "--port", str(port), "--log-level", "warning",
               "--timeout-worker-healthcheck", "60"]  # fmt: skip
    env = {**os.environ, "FLOOR_DATABASE_URL": database_url}
    log_dir = Path(tempfile.mkdtemp(prefix="depot-floor-"))
    with running(command, env, log_dir, f"http://127.0.0.1:{port}/healthz"):
        yield f"http://127.0.0.1:{port}"


def _line(name: str, rounds: list[Round], per_request: int) -> tuple[float, str]:
    requests = sum(r.requests for r in rounds)
    seconds = sum(r.seconds for r in rounds)
    rate = requests * per_request / seconds
    p50 = sorted(r.p50_ms for r in rounds)[len(rounds) // 2]
    p99 = max(r.p99_ms for r in rounds)
    failed = sum(r.failed for r in rounds)
    return rate, (
        f"  {name:<22} {rate:>9,.0f} events/s  p50 {p50:6.1f} ms  p99 {p99:6.1f} ms"
        f"  (not acknowledged: {failed})"
    )


def compare(
    servers: dict[str, tuple[str, list[str]]],
    *,
    batch: int,
    connections: int,
    single: str = "axle_count",
) -> None:
    """Alternating rounds against every server (url, device keys); prints rates and ratios."""
    rounds: dict[str, list[Round]] = {name: [] for name in servers}
    for n in range(ROUNDS):
        for name, (url, keys) in servers.items():  # alternating: drift hits every server alike
            prefix = f"{name[:5]}-{batch}-{single[:2]}-{n}"
            rounds[name].append(
                drive(
                    url,
                    keys,
                    prefix,
                    batch=batch,
                    connections=connections,
                    seconds=SECONDS,
                    single=single,
                )
            )
    what = f"single {single} events" if batch == 0 else f"batches of {batch} heartbeats"
    print(f"{what}, {connections} connections, {ROUNDS} rounds of {SECONDS:g} s:")
    rates = {}
    for name, result in rounds.items():
        rates[name], line = _line(name, result, batch or 1)
        print(line)
    for name in servers:
        if name != "floor":
            print(f"  ratio {name} / floor: {rates[name] / rates['floor']:.2f}×")


def latency_by_connections(servers: dict[str, tuple[str, list[str]]]) -> None:
    """p50/p99 of single axle counts against the number of connections, floor and depot side
    by side: where on this machine a p99 of ``P99_TARGET_MS`` is reachable at all, and whether
    depot's tail follows the floor's (the machine's) or its own."""
    print(f"single axle_count events by connections, one round of {SECONDS:g} s each:")
    for connections in SWEEP_CONNECTIONS:
        cells = []
        for name, (url, keys) in servers.items():
            got = drive(url, keys, f"sw-{name[:5]}-{connections}", batch=0,
                        connections=connections, seconds=SECONDS)  # fmt: skip
            rate = got.requests / got.seconds
            cells.append(f"{name} {rate:,.0f}/s p50 {got.p50_ms:.1f} p99 {got.p99_ms:.1f} ms")
        print(f"  {connections:>2} connections: " + " | ".join(cells))
    print(f"  (p99 target {P99_TARGET_MS:g} ms; the floor's own p99 says what the machine allows)")


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        prog="python -m bench.ingest", description="depot against the reference floor"
    )
    parser.add_argument(
        "--only",
        choices=["batches"],
        help="run only this comparison (batches: floor and depot, batches of 500 heartbeats)",
    )
    only = parser.parse_args(argv).only
    generator = "wrk" if have_wrk() else "the Python client (install wrk for the real figures)"
    print(f"load generator: {generator}")
    floor_db = bench_database("depot_bench_floor")
    if floor_db.startswith("sqlite"):
        print("the floor needs PostgreSQL; nothing measured")
        return
    if only == "batches":
        batches_only(floor_db)
    else:
        everything(floor_db)


def batches_only(floor_db: str) -> None:
    """The batch comparison alone: the floor and depot (group commit on, as by default)."""
    with ExitStack() as stack:
        quiet = {"DEPOT_ACCESS_LOG": "false"}
        grouped = stack.enter_context(serve(bench_database("depot_bench_ingest"), extra_env=quiet))
        keys = setup_depot(grouped)
        floor = stack.enter_context(serve_floor(floor_db, keys))
        servers = {"floor": (floor, keys), "depot group commit": (grouped, keys)}
        compare(servers, batch=BATCH, connections=BATCH_CONNECTIONS)


def everything(floor_db: str) -> None:
    with ExitStack() as stack:
        # Without uvicorn's access log, as the floor runs (``--log-level warning``).
        quiet = {"DEPOT_ACCESS_LOG": "false"}
        grouped = stack.enter_context(serve(bench_database("depot_bench_ingest"), extra_env=quiet))
        ungrouped = stack.enter_context(
            serve(
                bench_database("depot_bench_ingest_nogc"),
                extra_env={**quiet, "DEPOT_GROUP_COMMIT_MS": "0"},
            )
        )
        keys = setup_depot(grouped)
        keys_nogc = setup_depot(ungrouped)
        floor = stack.enter_context(serve_floor(floor_db, keys))
        servers = {
            "floor": (floor, keys),
            "depot group commit": (grouped, keys),
            "depot no group commit": (ungrouped, keys_nogc),
        }
        compare(servers, batch=0, connections=SINGLE_CONNECTIONS)
        # The same without a derivation (liveness only): what ingest itself costs.
        compare(servers, batch=0, connections=SINGLE_CONNECTIONS, single="heartbeat")
        compare(servers, batch=BATCH, connections=BATCH_CONNECTIONS)
        latency_by_connections({name: servers[name] for name in ("floor", "depot group commit")})
        snapshot_latency(grouped, background_keys=keys)


if __name__ == "__main__":
    main()
