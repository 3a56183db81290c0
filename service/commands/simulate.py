"""``depot simulate``: keep the demo line alive — heartbeats on schedule and a train every few
minutes with the usual mix of outcomes — so the review screen shows what a live line looks like.

It posts through the real device API, to a running server (``--url``) or in-process against the
configured database. It takes over the demo line's devices (a new key for each, printed nowhere;
every change is in the credential audit) or builds the demo line when the database is empty, and
refuses any other line. A train only enters a free section: a section in alarm or review waits
for the dispatcher, as on a real line. It ends on SIGTERM/SIGINT, after ``--duration``, or when
the server stops answering.
"""

from __future__ import annotations

import argparse
import signal
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from datetime import UTC, datetime, timedelta
from typing import TYPE_CHECKING, cast

import httpx
import numpy as np

from core.settings import get_settings

if TYPE_CHECKING:
    from service.inprocess import TestClient
from service.commands._common import NON_NEGATIVE, POSITIVE, SEED, fail
from service.demo import END_KINDS, FLEET, SECTIONS, STATIONS, DemoLine, Trip

__all__ = ["register"]

OUTCOMES = ("complete", "lost_car", "missing_evidence")
STOP_SIGNALS = (signal.SIGTERM, signal.SIGINT)


@dataclass(frozen=True)
class Schedule:
    """How the simulated line behaves.

    Attributes
    ----------
    train_every_s : seconds between departures (when a section is free).
    transit_s : seconds a train takes through its section.
    heartbeat_every_s : seconds between heartbeats of every device (below the heartbeat period).
    outcome_weights : chance of each of ``OUTCOMES``: arrives complete, loses its last car, the
        arrival camera misses the last car (evidence missing: a person must look).
    give_up_s : the server is taken as stopped after this long without an answer.
    """

    train_every_s: float = 180.0
    transit_s: float = 90.0
    heartbeat_every_s: float = 20.0
    outcome_weights: tuple[float, float, float] = (0.7, 0.15, 0.15)
    give_up_s: float = 15.0


@dataclass
class Running:
    trip: Trip
    outcome: str
    arrives_at: float  # monotonic


@dataclass
class Simulator:
    line: DemoLine
    schedule: Schedule
    rng: np.random.Generator
    stop: threading.Event
    running: dict[str, Running] = field(default_factory=dict)
    trains: int = 4000
    directions: dict[str, int] = field(default_factory=dict)
    waiting: str = ""  # the held sections last reported, so that it is said once

    def heartbeats(self) -> None:
        self.line.heartbeats(datetime.now(UTC))

    def free_sections(self) -> list[str]:
        got = self.line.client.get("/api/v1/sections", headers=self.line.admin)
        got.raise_for_status()
        states = {s["id"]: s["state"] for s in got.json()}
        # Only the demo line's sections: an operator's own sections are never driven.
        ours = {section[0] for section in SECTIONS}
        free = [
            i
            for i, state in states.items()
            if state == "free" and i in ours and i not in self.running
        ]
        held = ", ".join(f"{i} {state}" for i, state in states.items() if state != "free")
        if not free and held != self.waiting:
            _say(f"no free section ({held}): the next train waits for the dispatcher")
        self.waiting = "" if free else held
        return free

    def depart(self, section: str) -> None:
        _, a, b, _ = next(s for s in SECTIONS if s[0] == section)
        flip = self.directions.get(section, 0)
        self.directions[section] = 1 - flip
        origin, destination = (a, b) if flip == 0 else (b, a)
        self.trains += 1
        length = int(self.rng.integers(5, 11))
        first = int(self.rng.integers(0, len(FLEET) - length))
        now = datetime.now(UTC)
        trip = Trip(
            section, origin, destination, str(self.trains), FLEET[first : first + length], now
        )
        outcome = str(self.rng.choice(OUTCOMES, p=list(self.schedule.outcome_weights)))
        self.line.read_cars(origin, trip, trip.cars, now - timedelta(seconds=2 * length + 3))
        cam = f"{origin}-{section}-cam"
        self.line.snapshot(cam, now - timedelta(seconds=1), disc=True, condition="day")
        self.line.post(f"{origin}-ilk", "train_departed", now, section=section, train=trip.train)
        self.running[section] = Running(trip, outcome, time.monotonic() + self.schedule.transit_s)
        _say(f"train {trip.train} departs {origin}→{destination} on {section}, {length} cars")

    def arrive(self, section: str) -> None:
        going = self.running.pop(section)
        trip, lost = going.trip, 1 if going.outcome == "lost_car" else 0
        now = datetime.now(UTC)
        cars = trip.cars[: len(trip.cars) - lost]
        self.line.read_cars(
            trip.destination, trip, cars, now - timedelta(seconds=2 * len(cars) + 3)
        )
        if going.outcome != "missing_evidence":
            cam = f"{trip.destination}-{section}-cam"
            self.line.snapshot(cam, now - timedelta(seconds=1), disc=lost == 0, condition="day")
        answer = self.line.post(
            f"{trip.destination}-ilk", "train_arrived", now, section=section, train=trip.train
        )
        verdict = answer.get("verdict") or "not decided yet (evidence outstanding)"
        verdict += f", section {answer['section_state']}" if "section_state" in answer else ""
        _say(f"train {trip.train} arrives at {trip.destination} ({going.outcome}): {verdict}")

    def tick(self, now: float, due: dict[str, float]) -> None:
        if now >= due["heartbeat"]:
            self.heartbeats()
            due["heartbeat"] = now + self.schedule.heartbeat_every_s
        for section, going in list(self.running.items()):
            if now >= going.arrives_at:
                self.arrive(section)
        if now >= due["train"]:
            free = self.free_sections()
            if free:
                self.depart(free[int(self.rng.integers(0, len(free)))])
                due["train"] = now + self.schedule.train_every_s
            else:
                due["train"] = now + min(10.0, self.schedule.train_every_s)

    def loop(self, until: float | None) -> None:
        due = {"heartbeat": 0.0, "train": time.monotonic() + min(5.0, self.schedule.train_every_s)}
        last_answer = time.monotonic()
        while not self.stop.is_set() and (until is None or time.monotonic() < until):
            try:
                self.tick(time.monotonic(), due)
                last_answer = time.monotonic()
            except (httpx.TransportError, httpx.HTTPStatusError, RuntimeError) as exc:
                # A restart or a refused event is retried on the next tick; a server silent
                # for give_up_s has stopped, and the simulation stops with it.
                if time.monotonic() - last_answer > self.schedule.give_up_s:
                    raise ServerGone(str(exc)) from exc
                if isinstance(exc, RuntimeError):
                    _say(f"refused: {exc}")
            self.stop.wait(0.5)


class ServerGone(Exception):
    """The server stopped answering: the simulation ends with it."""


def _say(message: str) -> None:
    print(f"{datetime.now(UTC):%H:%M:%S} simulate: {message}", flush=True)


def take_over(line: DemoLine) -> str:
    """Build the demo line in an empty database, or take the demo line's device keys."""
    listed = line.client.get("/api/v1/devices", headers=line.admin)
    listed.raise_for_status()
    devices = [d["id"] for d in listed.json()]
    if not devices:
        line.build()
        return f"built the demo line ({len(line.keys)} devices)"
    wanted = demo_device_ids()
    missing = sorted(set(wanted) - set(devices))
    if missing:
        raise LookupError(
            f"this database holds another line (no device {', '.join(missing[:3])}); depot"
            " simulate drives only the demo line: run it on a fresh database or after depot demo"
        )
    for ident in wanted:
        answer = line.client.post(f"/api/v1/devices/{ident}/key", headers=line.admin)
        answer.raise_for_status()
        line.keys[ident] = {"X-Device-Key": answer.json()["key"]}
    return f"took over the demo line's {len(wanted)} devices (new keys, in the credential audit)"


def demo_device_ids() -> list[str]:
    """The ids ``DemoLine.build`` registers, in its order (mirrors service.demo)."""
    ids = [f"{s}-ilk" for s, _ in STATIONS]
    for section, origin, destination, _ in SECTIONS:
        for station in (origin, destination):
            ids += [f"{station}-{section}-{short}" for short, _ in END_KINDS]
    return [*ids, "D-mark", "D-bench"]


def _when_answering(line: DemoLine, wait_s: float) -> str:
    """Take over the line once the server answers (``make run`` starts both at once)."""
    deadline = time.monotonic() + wait_s
    while True:
        try:
            return take_over(line)
        except httpx.TransportError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.5)


@contextmanager
def _client(url: str | None) -> Iterator[httpx.Client]:
    if url is None:
        from service.app import create_app
        from service.inprocess import TestClient

        with TestClient(create_app()) as client:
            yield client
    else:
        with httpx.Client(base_url=url.rstrip("/"), timeout=10.0) as client:
            yield client


def _simulate(args: argparse.Namespace) -> int:
    for name in ("train_every", "transit", "heartbeat_every"):
        if getattr(args, name) <= 0:
            return fail(f"--{name.replace('_', '-')} must be above 0 seconds")
    if args.heartbeat_every >= get_settings().heartbeat_s:
        return fail(
            f"--heartbeat-every {args.heartbeat_every:g} is not below the heartbeat period"
            f" DEPOT_HEARTBEAT_S={get_settings().heartbeat_s:g}: devices would look silent"
        )
    schedule = Schedule(args.train_every, args.transit, args.heartbeat_every)
    stop = threading.Event()
    previous = {sig: signal.signal(sig, lambda *_: stop.set()) for sig in STOP_SIGNALS}
    try:
        return _run(args, schedule, stop)
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def _run(args: argparse.Namespace, schedule: Schedule, stop: threading.Event) -> int:
    trains = 0
    try:
        with _client(args.url) as client:
            line = DemoLine(cast("TestClient", client))
            line.serial = int(time.time() * 1000)  # event ids never reuse the demo day's
            try:
                _say(_when_answering(line, args.wait))
            except httpx.TransportError:
                return fail(f"no server answers at {args.url}; start it (depot serve) first")
            sim = Simulator(line, schedule, np.random.default_rng(args.seed), stop)
            until = None if args.duration is None else time.monotonic() + args.duration
            try:
                sim.loop(until)
            finally:
                trains = sim.trains - 4000
    except LookupError as exc:
        return fail(str(exc))
    except (httpx.TransportError, ServerGone) as exc:
        print(f"depot: the server stopped answering ({exc}); simulation ended", file=sys.stderr)
        return 0
    except httpx.HTTPStatusError as exc:
        return fail(f"the server refused {exc.request.url.path}: {exc.response.text[:200]}")
    _say(f"stopped after {trains} trains")
    return 0


def register(subparsers: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Add ``simulate`` to ``depot``'s sub-command parser."""
    p = subparsers.add_parser(
        "simulate", help="keep the demo line alive: heartbeats and a train every few minutes"
    )
    p.add_argument(
        "--url", help="a running server, e.g. http://127.0.0.1:8000 (default: in-process)"
    )
    p.add_argument(
        "--train-every",
        type=POSITIVE,
        default=Schedule.train_every_s,
        metavar="S",
        help="seconds between trains sent into a free section",
    )
    p.add_argument(
        "--transit",
        type=POSITIVE,
        default=Schedule.transit_s,
        metavar="S",
        help="seconds from departure to arrival",
    )
    p.add_argument(
        "--heartbeat-every",
        type=POSITIVE,
        default=Schedule.heartbeat_every_s,
        metavar="S",
        help="seconds between each device's heartbeats",
    )
    p.add_argument(
        "--duration",
        type=POSITIVE,
        default=None,
        metavar="S",
        help="stop after S seconds (default: run until stopped)",
    )
    p.add_argument(
        "--wait", type=NON_NEGATIVE, default=30.0, metavar="S", help="wait S seconds for the server"
    )
    p.add_argument(
        "--seed", type=SEED, default=None, help="outcomes repeatable with a seed (default: random)"
    )
    p.set_defaults(func=_simulate)
