"""The load generator of the ingest benchmark: ``wrk`` with a Lua script, else a Python client.

``wrk`` comes from Debian: ``apt-get install -y wrk``. Both generators post the same bodies
(unique ``event_id`` per request, device keys in rotation, one request per device at a time,
as devices send) for a fixed time with a fixed number of connections, and report requests,
the p50/p99 latency and anything not acknowledged.
"""

from __future__ import annotations

import asyncio
import json
import shutil
import statistics
import subprocess
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import httpx

LUA = r"""
local keys = {%(keys)s}
local prefix = "%(prefix)s"
local batch = %(batch)d
local nthreads = %(threads)d
local single = "%(single)s"
local counter = 0
local threads = 0
-- ``me`` is a global that setup() gives each thread's own Lua state; a ``local me`` here would
-- shadow it, and every thread would then send the same event_ids (half the load duplicates).

function setup(thread)
  threads = threads + 1
  thread:set("me", threads)
end

local function event(id, kind)
  if kind == "heartbeat" then
    return '{"event_id":"' .. id .. '","occurred_at":"2026-11-23T10:00:00Z","kind":"heartbeat"}'
  end
  return '{"event_id":"' .. id .. '","occurred_at":"2026-11-23T10:00:00Z",'
    .. '"kind":"axle_count","section":"AB","axles":' .. (4 * (counter %% 50)) .. '}'
end

request = function()
  counter = counter + 1
  -- Thread ``me`` of ``nthreads`` takes every nthreads-th key in turn: the threads never share
  -- a device, and one device has one request in flight at a time, as a device sends.
  local key = keys[((counter - 1) * nthreads + me - 1) %% #keys + 1]
  local id = prefix .. "-" .. me .. "-" .. counter
  local body
  if batch == 0 then
    body = event(id, single)
  else
    local parts = {}
    for n = 1, batch do parts[n] = event(id .. "-" .. n, "heartbeat") end
    body = '{"events":[' .. table.concat(parts, ",") .. ']}'
  end
  return wrk.format("POST", "/api/v1/events",
    {["Content-Type"] = "application/json", ["X-Device-Key"] = key}, body)
end

done = function(summary, latency, requests)
  local e = summary.errors
  io.write(string.format(
    'WRK {"requests":%%d,"duration_us":%%d,"failed":%%d,"p50_us":%%d,"p99_us":%%d}\n',
    summary.requests, summary.duration, e.connect + e.read + e.write + e.status + e.timeout,
    latency:percentile(50), latency:percentile(99)))
end
"""


WRK_THREADS = 2


@dataclass(frozen=True)
class Round:
    """One timed round against one server: acknowledged requests and their latency."""

    requests: int
    seconds: float
    failed: int
    p50_ms: float
    p99_ms: float


def have_wrk() -> bool:
    return shutil.which("wrk") is not None


@dataclass(frozen=True)
class Load:
    """What one round sends: to ``url``, with device ``keys`` in rotation, ``event_id``s
    starting with ``prefix``; ``batch`` 0 posts single events of kind ``single``
    (``axle_count`` or ``heartbeat``), else batches of ``batch`` heartbeats; ``connections``
    at once for ``seconds``."""

    url: str
    keys: list[str]
    prefix: str
    batch: int
    connections: int
    seconds: float
    single: str = "axle_count"


def _wrk(load: Load) -> Round:
    script = LUA % {
        "keys": ", ".join(f'"{k}"' for k in load.keys),
        "prefix": load.prefix,
        "batch": load.batch,
        "threads": WRK_THREADS,
        "single": load.single,
    }
    with tempfile.NamedTemporaryFile("w", suffix=".lua", delete=False) as handle:
        handle.write(script)
    try:
        done = subprocess.run(
            ["wrk", f"-t{WRK_THREADS}", f"-c{load.connections}", f"-d{load.seconds:g}s",
             "--timeout", "30s", "-s", handle.name, load.url],
            capture_output=True, text=True, check=True, timeout=load.seconds + 60,
        )  # fmt: skip
    finally:
        Path(handle.name).unlink()
    line = next(x for x in done.stdout.splitlines() if x.startswith("WRK "))
    figures = json.loads(line[4:])
    return Round(
        requests=figures["requests"] - figures["failed"],
        seconds=figures["duration_us"] / 1e6,
        failed=figures["failed"],
        p50_ms=figures["p50_us"] / 1000,
        p99_ms=figures["p99_us"] / 1000,
    )


def _body(prefix: str, n: int, batch: int, single: str) -> dict[str, object]:
    if batch == 0 and single == "heartbeat":
        return {"event_id": f"{prefix}-{n}", "occurred_at": "2026-11-23T10:00:00Z", "kind": single}
    if batch == 0:
        return {
            "event_id": f"{prefix}-{n}",
            "occurred_at": "2026-11-23T10:00:00Z",
            "kind": "axle_count",
            "section": "AB",
            "axles": 4 * (n % 50),
        }
    return {
        "events": [
            {"event_id": f"{prefix}-{n}-{k}", "occurred_at": "2026-11-23T10:00:00Z",
             "kind": "heartbeat"}
            for k in range(batch)
        ]
    }  # fmt: skip


async def _python(load: Load) -> Round:
    latencies: list[float] = []
    failed = 0
    deadline = time.perf_counter() + load.seconds

    async def connection(c: int, client: httpx.AsyncClient) -> None:
        nonlocal failed
        n = 0
        while time.perf_counter() < deadline:
            n += 1
            start = time.perf_counter()
            response = await client.post(
                "/api/v1/events",
                json=_body(f"{load.prefix}-{c}", n, load.batch, load.single),
                headers={"X-Device-Key": load.keys[(c + load.connections * n) % len(load.keys)]},
            )
            if response.status_code in (200, 201):
                latencies.append(time.perf_counter() - start)
            else:
                failed += 1

    limits = httpx.Limits(max_connections=load.connections)
    async with httpx.AsyncClient(base_url=load.url, limits=limits, timeout=30) as client:
        start = time.perf_counter()
        await asyncio.gather(*(connection(c, client) for c in range(load.connections)))
        elapsed = time.perf_counter() - start
    q = statistics.quantiles(latencies, n=100) if len(latencies) > 2 else [0.0] * 99
    return Round(len(latencies), elapsed, failed, q[49] * 1000, q[98] * 1000)


def drive(
    url: str,
    keys: list[str],
    prefix: str,
    *,
    batch: int,
    connections: int,
    seconds: float,
    single: str = "axle_count",
) -> Round:
    """One round of load (see :class:`Load`), by ``wrk`` when installed, else in Python."""
    load = Load(url, keys, prefix, batch, connections, seconds, single)
    return _wrk(load) if have_wrk() else asyncio.run(_python(load))
