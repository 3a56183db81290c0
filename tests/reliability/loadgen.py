"""Simulated station devices: a line of five block sections, 50 devices, trains in rounds.

Each round every section sees one train: the departure, then the readers' evidence from both
ends and everyone's heartbeats, then the arrival. Barriers between the three phases keep the
causal order a real line has (a train departs before it is read and arrives after), while the
devices inside a phase post concurrently. A device posts until it is acknowledged (201/200),
retrying with the same ``event_id`` after connection errors and 503s, within a deadline.
"""

from __future__ import annotations

import statistics
import threading
import time
from collections import Counter
from dataclasses import dataclass, field
from datetime import UTC, datetime, timedelta
from typing import Any

import cv2
import httpx
import numpy as np

from identification.simulate import ir_pulses_passage, wheel_mark_passage
from tail_check.synth import render_snapshot
from tests.service.linekit import BANDS

STATIONS = [f"S{i}" for i in range(6)]
SECTIONS = [(f"S{i}S{i + 1}", f"S{i}", f"S{i + 1}") for i in range(5)]
END_KINDS = (
    ("cam", "camera"),
    ("ac", "axle_counter"),
    ("ir", "ir_reader"),
    ("wm", "wheel_mark_reader"),
)
SPARE = (
    ("D-mark", "marking_station"),
    ("D-bench", "test_bench"),
    ("T1-obu", "onboard_unit"),
    ("T2-obu", "onboard_unit"),
)
CARS_PER_TRAIN = 6
T0 = datetime(2026, 11, 23, 6, 0, tzinfo=UTC)


def iso(at: datetime) -> str:
    return at.isoformat().replace("+00:00", "Z")


def car_codes(section_index: int) -> list[int]:
    return [100 + 10 * section_index + k for k in range(CARS_PER_TRAIN)]


@dataclass
class Device:
    id: str
    kind: str
    station: str
    section: str | None
    key: str = ""


@dataclass
class Stats:
    """What the devices saw; shared by all device threads (guarded by ``lock``)."""

    lock: threading.Lock = field(default_factory=threading.Lock)
    latencies: list[float] = field(default_factory=list)
    statuses: Counter[int] = field(default_factory=Counter)
    acked: dict[tuple[str, str], int] = field(default_factory=dict)
    sent: dict[tuple[str, str], dict[str, Any]] = field(default_factory=dict)
    unexpected: list[str] = field(default_factory=list)
    connection_errors: int = 0
    missing_retry_after: int = 0
    unacked: list[tuple[str, str]] = field(default_factory=list)
    elapsed: float = 0.0

    def summary(self) -> dict[str, Any]:
        q = statistics.quantiles(self.latencies, n=100) if len(self.latencies) > 2 else [0.0] * 99
        return {
            "events_acked": len(self.acked),
            "requests": len(self.latencies),
            "seconds": round(self.elapsed, 1),
            "events_per_s": round(len(self.acked) / self.elapsed, 1) if self.elapsed else 0.0,
            "p50_ms": round(q[49] * 1000, 1),
            "p99_ms": round(q[98] * 1000, 1),
            "statuses": dict(sorted(self.statuses.items())),
            "connection_errors": self.connection_errors,
            "unexpected": len(self.unexpected),
            "unacked": len(self.unacked),
        }


def line_devices() -> list[Device]:
    devices = [Device(f"{s}-ilk", "interlocking", s, None) for s in STATIONS]
    for section, a, b in SECTIONS:
        for station, end in ((a, "d"), (b, "a")):
            for short, kind in END_KINDS:
                devices.append(Device(f"{section}-{end}{short}", kind, station, section))
    devices += [Device(ident, kind, "S0", None) for ident, kind in SPARE]
    return devices


def build_line(url: str, admin: dict[str, str]) -> list[Device]:
    """Stations, sections, 50 devices (keys filled in) and the cars, through the real API."""
    devices = line_devices()
    with httpx.Client(base_url=f"{url}/api/v1", headers=admin, timeout=30) as client:
        for station in STATIONS:
            client.post("/stations", json={"id": station, "name": station}).raise_for_status()
        for section, a, b in SECTIONS:
            body = {"id": section, "from_station": a, "to_station": b, "mode": "primary"}
            client.post("/sections", json=body).raise_for_status()
        for device in devices:
            body = {
                "id": device.id,
                "station": device.station,
                "section": device.section,
                "kind": device.kind,
            }
            response = client.post("/devices", json=body)
            response.raise_for_status()
            device.key = response.json()["key"]
        for index in range(len(SECTIONS)):
            for code in car_codes(index):
                body = {"id": f"0{code}", "wheel_code": code, "ir_number": code, "axles": 4}
                client.post("/cars", json=body).raise_for_status()
        for band in BANDS:  # the test bench's values must name registered parameters
            client.post("/maintenance/parameters", json=band).raise_for_status()
    return devices


def tail_jpeg() -> bytes:
    image, _ = render_snapshot(3, disc=True, condition="day", distractors=(), occlusion=0.0)
    ok, data = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, 90])
    assert ok
    return bytes(data.tobytes())


def tagged_jpeg(jpeg: bytes, tag: str) -> bytes:
    """The same picture with a JPEG comment segment: each camera shot is its own file."""
    comment = tag.encode()
    return jpeg[:2] + b"\xff\xfe" + (len(comment) + 2).to_bytes(2, "big") + comment + jpeg[2:]


class Payloads:
    """Reader payloads made once (the simulators are slow compared with a post)."""

    def __init__(self) -> None:
        rng = np.random.default_rng(8)
        codes = [c for i in range(len(SECTIONS)) for c in car_codes(i)]
        self.wheel = {c: wheel_mark_passage(c, direction=1, rng=rng) for c in codes}
        self.pulses = {c: ir_pulses_passage(c, speed_kmh=40, rng=rng) for c in codes}
        self.jpeg = tail_jpeg()


Posting = tuple[str, dict[str, Any]]  # ("event" | "snapshot", body or form fields)


def _section_index(section: str) -> int:
    return int(section[1])


def _train(round_: int, section_index: int) -> str:
    return f"{round_ % 900 + 100}{section_index}"


def _ev(device: Device, tag: str, at: datetime, kind: str, **fields: Any) -> Posting:
    return "event", {
        "event_id": f"{device.id}-{tag}",
        "occurred_at": iso(at),
        "kind": kind,
        **fields,
    }


def _reader_events(device: Device, r: int, t: datetime, p: Payloads) -> list[Posting]:
    assert device.section is not None
    index = _section_index(device.section)
    arrival = device.id.split("-")[-1].startswith("a")
    at = t + timedelta(seconds=17 if arrival else 2)
    section, cars = device.section, car_codes(index)
    if device.kind == "camera":
        form = {"event_id": f"{device.id}-r{r}", "occurred_at": iso(at), "section": section}
        return [("snapshot", form)]
    if device.kind == "axle_counter":
        return [_ev(device, f"r{r}", at, "axle_count", section=section, axles=4 * len(cars))]
    out = []
    for k, code in enumerate(cars):
        at_k, tag = at + timedelta(seconds=1 + k), f"r{r}-{k}"
        if device.kind == "wheel_mark_reader":
            out.append(_ev(device, tag, at_k, "wheel_marks", section=section, **p.wheel[code]))
        elif arrival:
            out.append(_ev(device, tag, at_k, "ir_pulses", section=section, **p.pulses[code]))
        else:
            out.append(_ev(device, tag, at_k, "ir_id", section=section, reads=[code] * 5))
    return out


def _spare_events(device: Device, r: int, t: datetime) -> list[Posting]:
    at = t + timedelta(seconds=10)
    if device.kind == "marking_station":
        code = car_codes(r % len(SECTIONS))[0]
        return [
            _ev(
                device,
                f"r{r}",
                at,
                "wheel_marks_written",
                car=f"0{code}",
                code=code,
                detections=["W1", "W2"] * 4,
            )
        ]
    if device.kind == "test_bench":
        values = {"brake_cylinder_fill_s": 3.0 + (r % 7) / 10, "door_close_s": 2.4}
        return [_ev(device, f"r{r}", at, "measurement", car="0100", values=values)]
    return [
        _ev(
            device,
            f"r{r}-{k}",
            at + timedelta(seconds=k),
            "motion_sample",
            train=device.id[:2],  # one on-board unit per train
            t=float(r * 300 + k),
            accel_mps2=-0.1 * k,
            gnss_speed_mps=15.0,
        )
        for k in range(3)
    ]


def events_for(device: Device, r: int, phase: int, p: Payloads) -> list[Posting]:
    """What one device posts in one phase of round ``r`` (0 depart, 1 evidence, 2 arrive)."""
    t = T0 + timedelta(minutes=5 * r)
    if device.kind == "interlocking":
        s = int(device.station[1:])
        if phase == 0 and s < len(SECTIONS):
            section = SECTIONS[s][0]
            return [
                _ev(device, f"r{r}-dep", t, "train_departed", section=section, train=_train(r, s))
            ]
        if phase == 2 and s > 0:
            section = SECTIONS[s - 1][0]
            at = t + timedelta(seconds=30)
            return [
                _ev(
                    device,
                    f"r{r}-arr",
                    at,
                    "train_arrived",
                    section=section,
                    train=_train(r, s - 1),
                )
            ]
    if phase != 1:
        return []
    out: list[Posting] = []
    if device.section is not None:
        out = _reader_events(device, r, t, p)
    elif device.kind != "interlocking":
        out = _spare_events(device, r, t)
    return [*out, _ev(device, f"r{r}-hb", t + timedelta(seconds=25), "heartbeat")]


def post_until_acked(
    client: httpx.Client,
    stats: Stats,
    device: Device,
    posting: Posting,
    p: Payloads,
    deadline: float,
) -> None:
    """Post one event until it is acknowledged; the same ``event_id`` on every retry."""
    what, body = posting
    key = (device.id, str(body["event_id"]))
    with stats.lock:
        stats.sent[key] = body
    while time.monotonic() < deadline:
        start = time.perf_counter()
        try:
            if what == "event":
                response = client.post("/api/v1/events", json=body)
            else:
                image = tagged_jpeg(p.jpeg, key[1])
                files = {"image": ("tail.jpg", image, "image/jpeg")}
                response = client.post("/api/v1/snapshots", data=body, files=files)
        except httpx.TransportError:
            with stats.lock:
                stats.connection_errors += 1
            time.sleep(0.2)
            continue
        with stats.lock:
            stats.latencies.append(time.perf_counter() - start)
            stats.statuses[response.status_code] += 1
            if response.status_code in (200, 201):
                stats.acked[key] = response.status_code
                return
            if response.status_code < 500:
                stats.unexpected.append(f"{response.status_code} {key}: {response.text[:300]}")
                return
            if (
                response.status_code != 503
            ):  # a server error: noted, and retried like a device would
                stats.unexpected.append(f"{response.status_code} {key}: {response.text[:300]}")
            elif "retry-after" not in response.headers:
                stats.missing_retry_after += 1
        time.sleep(0.3)  # Retry-After says 5 s; a test device retries sooner, bounded anyway
    with stats.lock:
        stats.unacked.append(key)


def run_load(
    url: str,
    devices: list[Device],
    p: Payloads,
    *,
    seconds: float,
    give_up_after: float = 180,
    max_rounds: int = 500,
) -> Stats:
    """All devices, one thread each, round after round until ``seconds`` have passed."""
    stats = Stats()
    stop = threading.Event()
    crossings = [0]
    start = time.monotonic()
    deadline = start + seconds + give_up_after
    # The load's duration counts from the first crossing, when every device is ready: on a
    # busy machine starting 50 clients can take longer than the whole load.
    ready = [start]

    def at_barrier() -> None:
        if crossings[0] == 0:
            ready[0] = time.monotonic()
        elif crossings[0] % 3 == 0 and (
            time.monotonic() - ready[0] >= seconds or crossings[0] >= 3 * max_rounds
        ):
            stop.set()
        crossings[0] += 1

    barrier = threading.Barrier(len(devices), action=at_barrier, timeout=give_up_after)

    def device_loop(device: Device) -> None:
        headers = {"X-Device-Key": device.key}
        with httpx.Client(base_url=url, headers=headers, timeout=30) as client:
            for r in range(max_rounds):
                for phase in range(3):
                    barrier.wait()
                    if stop.is_set():
                        return
                    for posting in events_for(device, r, phase, p):
                        post_until_acked(client, stats, device, posting, p, deadline)

    def guarded(device: Device) -> None:
        try:
            device_loop(device)
        except Exception as exc:
            with stats.lock:
                stats.unexpected.append(f"{device.id}: {type(exc).__name__}: {exc}")
            barrier.abort()

    threads = [threading.Thread(target=guarded, args=(d,), daemon=True) for d in devices]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(timeout=max(1.0, deadline - time.monotonic() + 5))
    stats.elapsed = time.monotonic() - start
    return stats
