"""The kit of the independent passage-liveness trial (``test_service_trial_liveness*.py``).

Every event is played in the order the server receives it (``Plan``); the server's clock is the
test's (``tests/service/clock``). Unless a case says otherwise the line is healthy: every device
at A and B heartbeats as a live line does (each 55 s and at the end of the time it is alive,
``scenario.alive_times``), the train is read, counted and photographed at both ends.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from datetime import datetime, timedelta
from typing import Any

from sqlalchemy.orm import Session

from service.replay import replay
from tests.service.conflictkit import run_of
from tests.service.scenario import T0, Line, alive_times, jpeg
from tests.service.test_service_replay import snapshot_of_state

S = timedelta(seconds=1)
M = timedelta(minutes=1)
ARRIVE = T0 + 12 * M
A_END = ("A-cam", "A-ac", "A-ir", "A-wm")
B_END = ("B-cam", "B-ac", "B-ir", "B-wm", "B-eot")
ENDS = ("A-ilk", "B-ilk", *A_END, *B_END)
CARS = [117, 118, 119, 120]


def grid(start: datetime, end: datetime, step: timedelta) -> list[datetime]:
    """``start`` and each ``step`` after it up to ``end`` (``end`` only when on the grid)."""
    times, at = [], start
    while at <= end:
        times.append(at)
        at += step
    return times


@dataclass
class Plan:
    """Events to post, played sorted by the instant the server receives each."""

    line: Line
    items: list[tuple[datetime, int, str, Callable[[], Any]]] = field(default_factory=list)
    results: dict[str, Any] = field(default_factory=dict)

    def add(self, received: datetime, fn: Callable[[], Any], label: str = "") -> None:
        self.items.append((received, len(self.items), label, fn))

    def post(
        self,
        device: str,
        kind: str,
        at: datetime,
        received: datetime | None = None,
        label: str = "",
        **fields: Any,
    ) -> None:
        got = received or at
        self.add(got, lambda: self.line.post(device, kind, at, received=got, **fields), label)

    def beat(
        self,
        devices: Iterable[str],
        start: datetime,
        end: datetime,
        step: timedelta | None = None,
        dated: Callable[[datetime], datetime] = lambda at: at,
    ) -> None:
        """``devices`` heartbeat from ``start`` to ``end`` (receive times): each ``step`` from
        ``start`` (the boundary cases' exact timings), or by default as a live line does
        (``scenario.alive_times``: each 55 s and at ``end``); ``dated`` gives the device's
        clock for each."""
        times = alive_times(start, end) if step is None else grid(start, end, step)
        for device in devices:
            for at in times:
                self.post(device, "heartbeat", dated(at), received=at)

    def play(self) -> dict[str, Any]:
        for _, _, label, fn in sorted(self.items, key=lambda item: (item[0], item[1])):
            result = fn()
            if label:
                self.results[label] = result
        self.items.clear()
        return self.results


def evidence(
    plan: Plan,
    arrive: datetime = ARRIVE,
    *,
    skip: tuple[str, ...] = (),
    axles: tuple[int, int] = (16, 16),
    depart: datetime = T0,
    train: str = "2041",
) -> None:
    """A whole train of 4 cars (16 axles) seen at both ends; ``skip`` names devices that report
    nothing for it."""
    line = plan.line
    if "A-ir" not in skip:
        for i, car in enumerate(CARS):
            plan.post("A-ir", "ir_id", depart - 30 * S + i * S, section="AB", reads=[car] * 5)
    plan.post("A-ilk", "train_departed", depart, label="depart", section="AB", train=train)
    if "A-ac" not in skip:
        plan.post("A-ac", "axle_count", depart + 15 * S, section="AB", axles=axles[0])
    if "B-ir" not in skip:
        for i, car in enumerate(CARS):
            plan.post("B-ir", "ir_id", arrive - 40 * S + i * S, section="AB", reads=[car] * 5)
    if "B-ac" not in skip:
        plan.post("B-ac", "axle_count", arrive - 20 * S, section="AB", axles=axles[1])
    if "B-cam" not in skip:
        at = arrive - 5 * S
        plan.add(at, lambda: line.snapshot("B-cam", at, jpeg(disc=True, seed=21)))
    plan.post("B-ilk", "train_arrived", arrive, label="arrive", section="AB", train=train)


def replays_the_same(line: Line, session: Session) -> None:
    before = snapshot_of_state(line.client)
    counts = replay(session)
    session.commit()
    assert counts["failed"] == 0, counts
    assert snapshot_of_state(line.client) == before


def decision(line: Line, run: int) -> dict[str, Any]:
    result: dict[str, Any] = run_of(line, run)["decision"]
    return result


def names(line: Line, run: int, device: str) -> list[str]:
    return [r for r in decision(line, run)["reasons"] if device in r]


def assert_review_naming(line: Line, run: int, device: str) -> list[str]:
    decided = decision(line, run)
    assert decided["verdict"] == "undetermined", decided
    assert line.section()["state"] == "review", line.section()
    named = names(line, run, device)
    assert named, decided["reasons"]
    return named


def assert_free(line: Line, run: int) -> None:
    decided = decision(line, run)
    assert decided["verdict"] == "complete", decided
    assert line.section()["state"] == "free", (line.section(), decided)


# --- a healthy line -------------------------------------------------------------------------
