"""Wheel marks and infrared name the same cars, or the consist is not known (identification.md
§5: "when a car is read by both technologies, both must agree (a disagreement is reported)").

Found by an independent trial: the wheel-mark reader read car 0120 where the infrared reader
read 0118, at both ends; each technology's consist matched itself, the run was decided
``complete`` and the section freed, and the review screen said "same cars, same order" twice.
"""

from __future__ import annotations

from datetime import datetime, timedelta
from typing import Any

import pytest

from tests.conftest import ADMIN
from tests.service.reviewkit import TRANSIT
from tests.service.scenario import T0, Line, jpeg

ONE, ZERO, BASELINE = 2170, 1930, [2051, 2049, 2050, 2052, 2048, 2050]


def _wheel_marks(line: Line, end: str, cars: list[int], at: datetime) -> None:
    for i, car in enumerate(cars):
        axle = [ONE if bit == "1" else ZERO for bit in f"{car:08b}"]
        line.post(
            f"{end}-wm", "wheel_marks", at + timedelta(seconds=i),
            section="AB", direction=1, baseline=BASELINE, axles=[axle] * 4,
        )  # fmt: skip


def _passage(
    line: Line, wheel: tuple[list[int], list[int]], ir: tuple[list[int], list[int]]
) -> dict[str, Any]:
    """A train through AB with its tail disc seen on arrival; the readers of each end read
    ``wheel`` and ``ir`` (departure, arrival). Returns the run as the API shows it."""
    line.heartbeat_all(T0 - timedelta(seconds=20))
    _wheel_marks(line, "A", wheel[0], T0 - timedelta(seconds=30))
    line.read("A", ir[0], T0 - timedelta(seconds=30))
    run = line.depart(T0)
    arrive = T0 + TRANSIT
    line.heartbeat_all(arrive - timedelta(seconds=30))
    _wheel_marks(line, "B", wheel[1], arrive - timedelta(seconds=40))
    line.read("B", ir[1], arrive - timedelta(seconds=40))
    line.snapshot("B-cam", arrive - timedelta(seconds=5), jpeg(disc=True))
    line.arrive(arrive)
    shown: dict[str, Any] = line.client.get(f"/api/v1/runs/{run}", headers=ADMIN).json()
    return shown


CARS = [117, 118, 119]


def test_readers_that_agree_free_the_section(line: Line) -> None:
    run = _passage(line, (CARS, CARS), (CARS, CARS))
    assert run["decision"]["verdict"] == "complete", run["decision"]
    assert line.section()["state"] == "free"


@pytest.mark.parametrize(
    ("wheel", "ir", "named"),
    [
        # the trial's case: both ends read 0120 by wheel marks where infrared reads 0118
        (([117, 120, 119], [117, 120, 119]), (CARS, CARS), ("0120", "0118")),
        # only the arrival's readers disagree: infrared's "0118 lost" is not proven
        ((CARS, CARS), (CARS, [117, 120, 119]), ("0118", "0120")),
        # only the departure's
        (([117, 120, 119], CARS), (CARS, CARS), ("0120", "0118")),
        # one reader read a car the other did not
        ((CARS, CARS), ([117, 118, 119, 120], [117, 118, 119, 120]), ("3 cars", "4 cars")),
    ],
)
def test_readers_that_disagree_need_a_person(
    line: Line,
    wheel: tuple[list[int], list[int]],
    ir: tuple[list[int], list[int]],
    named: tuple[str, str],
) -> None:
    run = _passage(line, wheel, ir)
    assert run["decision"]["verdict"] == "undetermined", run
    assert line.section()["state"] == "review", line.section()
    said = " ".join(run["decision"]["reasons"])
    assert "wheel marks" in said and "infrared" in said and all(n in said for n in named), said
