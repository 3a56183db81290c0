"""``depot demo``: a demo line and a simulated day of traffic, posted through the real API.

Three stations, two single-track sections (AB primary, BC auxiliary), a camera, an infrared
reader, a wheel-mark reader and an axle counter at each end of each section, an interlocking per
station, a registered fleet; then a day of runs ending now, including a train that loses its
last two cars, an arrival photographed at night with a weak disc, and a reader gone silent;
a train carrying an end-of-train (EOT) unit whose radio reports the brake pipe at pressure on
arrival, and an arrival the camera missed, cleared by the next train sweeping the section.
"""

from __future__ import annotations

import logging
from collections import Counter
from dataclasses import dataclass, field
from datetime import UTC, datetime, timedelta
from typing import Any

import cv2
import httpx
import numpy as np
from sqlalchemy import select

from core.database import get_sessionmaker
from core.models import Station
from core.settings import get_settings
from identification.simulate import ir_pulses_passage, wheel_mark_passage
from service.fleet.demo import load_fleet_history
from service.inprocess import TestClient
from tail_check.synth import render_snapshot

STATIONS = (("A", "Anan'iv"), ("B", "Birzula"), ("C", "Podilsk"))
SECTIONS = (("AB", "A", "B", "primary"), ("BC", "B", "C", "auxiliary"))
END_KINDS = (
    ("cam", "camera"),
    ("ir", "ir_reader"),
    ("wm", "wheel_mark_reader"),
    ("ac", "axle_counter"),
    ("eot", "eot_receiver"),
)
# A real EOT packet (shared/data/real/eot_radio, PROVENANCE): unit 39572, 89 psig, marker on.
EOT_PACKET = "11100010010111100000101001010110010100110101001011101011011001110010101001"
FLEET = [f"0{n}" for n in range(101, 141)]


@dataclass
class Trip:
    section: str
    origin: str
    destination: str
    train: str
    cars: list[str]
    departs: datetime
    lose: int = 0
    arrival_condition: str = "day"
    weak_disc: bool = False
    arrival_image: bool = True
    eot_unit: int | None = None


@dataclass
class DemoLine:
    client: TestClient
    keys: dict[str, dict[str, str]] = field(default_factory=dict)
    silent: set[str] = field(default_factory=set)
    rng: np.random.Generator = field(default_factory=lambda: np.random.default_rng(2041))
    serial: int = 0

    @property
    def admin(self) -> dict[str, str]:
        return {"Authorization": f"Bearer {get_settings().admin_token}"}

    def setup(self, path: str, body: dict[str, Any]) -> dict[str, Any]:
        response = self.client.post(f"/api/v1/{path}", json=body, headers=self.admin)
        if response.status_code != 201:
            raise RuntimeError(
                f"demo setup {path} {body.get('id')}: {response.status_code} {response.text}"
            )
        result: dict[str, Any] = response.json()
        return result

    def build(self) -> None:
        for ident, name in STATIONS:
            self.setup("stations", {"id": ident, "name": name})
        for ident, origin, destination, mode in SECTIONS:
            self.setup(
                "sections",
                {"id": ident, "from_station": origin, "to_station": destination, "mode": mode},
            )
        devices: list[tuple[str, str, str | None, str]] = [
            (f"{s}-ilk", s, None, "interlocking") for s, _ in STATIONS
        ]
        for section, origin, destination, _ in SECTIONS:
            for station in (origin, destination):
                devices += [
                    (f"{station}-{section}-{short}", station, section, kind)
                    for short, kind in END_KINDS
                ]
        devices += [("D-mark", "A", None, "marking_station"), ("D-bench", "B", None, "test_bench")]
        for ident, station, served, kind in devices:
            key = self.setup(
                "devices", {"id": ident, "station": station, "section": served, "kind": kind}
            )["key"]
            self.keys[ident] = {"X-Device-Key": key}
        for car in FLEET:
            number = int(car)
            self.setup("cars", {"id": car, "wheel_code": number, "ir_number": number, "axles": 4})

    def post(self, device: str, kind: str, at: datetime, **fields: Any) -> dict[str, Any]:
        self.serial += 1
        body = {
            "event_id": f"{device}-{self.serial:06d}",
            "occurred_at": at.isoformat(),
            "kind": kind,
            **fields,
        }
        response = self.client.post("/api/v1/events", json=body, headers=self.keys[device])
        if response.status_code not in (200, 201):
            raise RuntimeError(
                f"demo event {kind} from {device}: {response.status_code} {response.text}"
            )
        result: dict[str, Any] = response.json()
        return result

    def heartbeats(self, at: datetime) -> None:
        for device in self.keys:
            if device not in self.silent:
                self.post(device, "heartbeat", at)

    def snapshot(
        self, device: str, at: datetime, *, disc: bool, condition: str, weak: bool = False
    ) -> None:
        seed = int(self.rng.integers(0, 2**31))
        image, _ = render_snapshot(
            seed,
            disc=disc,
            condition=condition,
            weak_disc=weak,
            distractors=(),
            occlusion=0.0,
            size=(640, 480),
        )
        ok, data = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, 90])
        assert ok
        self.serial += 1
        form = {
            "event_id": f"{device}-{self.serial:06d}",
            "occurred_at": at.isoformat(),
            "section": device.split("-")[1],
        }
        response = self.client.post(
            "/api/v1/snapshots",
            data=form,
            files={"image": ("tail.jpg", data.tobytes(), "image/jpeg")},
            headers=self.keys[device],
        )
        if response.status_code not in (200, 201):
            raise RuntimeError(
                f"demo snapshot from {device}: {response.status_code} {response.text}"
            )

    def read_cars(self, station: str, trip: Trip, cars: list[str], at: datetime) -> None:
        """The end's readers see the cars pass one by one, then the axle counter reports."""
        direction = 1 if station == trip.origin else 2
        for position, car in enumerate(cars):
            when = at + timedelta(seconds=2 * position)
            device = f"{station}-{trip.section}"
            if f"{device}-ir" not in self.silent:
                passage = ir_pulses_passage(
                    int(car), speed_kmh=5.0, rng=self.rng, spurious_rate=0.01
                )
                self.post(f"{device}-ir", "ir_pulses", when, section=trip.section, **passage)
            if f"{device}-wm" not in self.silent:
                marks = wheel_mark_passage(int(car), direction=direction, rng=self.rng)
                self.post(f"{device}-wm", "wheel_marks", when, section=trip.section, **marks)
        end = at + timedelta(seconds=2 * len(cars) + 1)
        self.post(
            f"{station}-{trip.section}-ac",
            "axle_count",
            end,
            section=trip.section,
            axles=4 * len(cars),
        )

    def run(self, trip: Trip) -> None:
        start = trip.departs
        self.heartbeats(start - timedelta(seconds=30))
        self.read_cars(trip.origin, trip, trip.cars, start - timedelta(seconds=60))
        self.snapshot(
            f"{trip.origin}-{trip.section}-cam",
            start - timedelta(seconds=5),
            disc=True,
            condition="day",
        )
        armed = {} if trip.eot_unit is None else {"eot_unit": trip.eot_unit}
        self.post(
            f"{trip.origin}-ilk",
            "train_departed",
            start,
            section=trip.section,
            train=trip.train,
            **armed,
        )
        arrives = start + timedelta(minutes=24)
        self.heartbeats(arrives - timedelta(seconds=90))
        arrived_cars = trip.cars[: len(trip.cars) - trip.lose]
        self.read_cars(trip.destination, trip, arrived_cars, arrives - timedelta(seconds=60))
        if trip.eot_unit is not None:
            self.post(
                f"{trip.destination}-{trip.section}-eot",
                "eot_status",
                arrives - timedelta(seconds=20),
                section=trip.section,
                unit_address=trip.eot_unit,
                pressure_psig=89,
                # the real packet's bits when the unit is the recorded one (the service checks)
                **(
                    {"marker_light": True, "motion": False, "bits": EOT_PACKET}
                    if trip.eot_unit == 39572
                    else {}
                ),
            )
        if trip.arrival_image:
            self.snapshot(
                f"{trip.destination}-{trip.section}-cam",
                arrives - timedelta(seconds=5),
                disc=trip.lose == 0,
                condition=trip.arrival_condition,
                weak=trip.weak_disc,
            )
        self.heartbeats(arrives - timedelta(seconds=2))
        self.post(
            f"{trip.destination}-ilk",
            "train_arrived",
            arrives,
            section=trip.section,
            train=trip.train,
        )

    def settle(self, section: str, reason: str, *, action: str = "clear") -> None:
        """A dispatcher clears a section left waiting (auxiliary mode, or a doubt looked at),
        or (``action="sweep"``) lets the next train prove it empty."""
        current = self.client.get(f"/api/v1/sections/{section}", headers=self.admin).json()
        run = current["run"]
        if current["state"] == "free" or run is None:
            return
        response = self.client.post(
            f"/api/v1/runs/{run['id']}/decision",
            json={"action": action, "reason": reason},
            headers=self.admin,
        )
        if response.status_code != 200:
            raise RuntimeError(
                f"demo decision on {section}: {response.status_code} {response.text}"
            )


def day_of_traffic(line: DemoLine, end: datetime) -> None:
    """Eight runs; the day ends with AB in alarm (lost cars) and BC in review (a silent reader).

    Early on: train 2041 carries EOT unit 39572, whose report at arrival joins the evidence;
    the camera misses 2039's arrival, the dispatcher asks for a sweep, and 2042 (the sweep run)
    arrives complete and clears it.
    """
    t = end - timedelta(hours=6)
    cars = FLEET
    # The day is posted in seconds and silence is judged by when the server received a
    # device's events: a reader that is to be silent at 2045's arrival is never heard from.
    line.silent.add("C-BC-ir")
    line.run(Trip("AB", "A", "B", "2041", cars[0:8], t - timedelta(hours=2), eot_unit=39572))
    line.run(Trip("AB", "B", "A", "2039", cars[8:14], t - timedelta(hours=1), arrival_image=False))
    line.settle("AB", "the camera missed the last car; the next train sweeps AB", action="sweep")
    line.run(
        Trip("AB", "B", "A", "2042", cars[8:14], t + timedelta(hours=1), arrival_condition="dusk")
    )
    line.settle("AB", "dusk images checked by eye; consist complete")
    line.run(Trip("BC", "B", "C", "2043", cars[14:24], t + timedelta(hours=1, minutes=30)))
    line.settle("BC", "auxiliary mode: consists and tail disc confirmed on the images")
    night = Trip(
        "BC",
        "C",
        "B",
        "2044",
        cars[24:30],
        t + timedelta(hours=2, minutes=30),
        arrival_condition="night",
        weak_disc=True,
    )
    line.run(night)
    line.settle("BC", "night image: the dim disc is visible by eye; axle counts agree")
    line.run(Trip("AB", "A", "B", "3107", cars[24:36], t + timedelta(hours=3), lose=2))
    line.run(Trip("BC", "B", "C", "2045", cars[0:6], t + timedelta(hours=5)))


def load_demo(*, force: bool = False, fleet: bool = True) -> int:
    from service.app import create_app

    with get_sessionmaker()() as session:
        if session.scalar(select(Station.id).limit(1)) is not None and not force:
            print("demo: the database already holds a line; nothing loaded (--force adds anyway)")
            return 0
    answers: Counter[int] = Counter()

    def count(response: httpx.Response) -> None:
        answers[response.status_code // 100 * 100] += 1

    app = create_app()
    # One summary line instead of a log line per request (create_app logs at INFO).
    logging.getLogger("httpx").setLevel(logging.WARNING)
    with TestClient(app) as client:
        client.event_hooks["response"].append(count)
        line = DemoLine(client)
        line.build()
        now = datetime.now(UTC).replace(microsecond=0)
        if fleet:
            load_fleet_history(client, line.admin, line.keys["D-bench"], FLEET, end=now)
        day_of_traffic(line, now - timedelta(minutes=5))
        states = {
            s["id"]: s["state"] for s in client.get("/api/v1/sections", headers=line.admin).json()
        }
    total = sum(answers.values())
    refused = {f"{k // 100}xx": n for k, n in sorted(answers.items()) if k != 200}
    print(
        f"demo: {total} requests through the API, "
        + (f"answered {refused} besides 2xx" if refused else "all answered 2xx")
    )
    print(
        f"demo: loaded {len(STATIONS)} stations, {len(line.keys)} devices,"
        f" {len(FLEET)} cars, 8 runs (one EOT-equipped, one sweep);"
        f" section states {states}"
    )
    return 0
