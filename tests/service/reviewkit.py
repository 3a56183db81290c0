"""Runs that need a person, posted as the devices would: for the review-screen tests."""

from __future__ import annotations

from datetime import datetime, timedelta

from tests.service.scenario import T0, Line, jpeg

TRANSIT = timedelta(minutes=20)


def review_run(line: Line, *, train: str = "2041", at: datetime = T0) -> int:
    """Four cars leave A and four reach B, but the arrival camera sees nothing: AB in review."""
    line.heartbeat_all(at - timedelta(seconds=20))
    line.read("A", [117, 118, 119, 120], at - timedelta(seconds=30))
    run = line.depart(at, train=train)
    arrive = at + TRANSIT
    line.heartbeat_all(arrive - timedelta(seconds=30))
    line.read("B", [117, 118, 119, 120], arrive - timedelta(seconds=40))
    line.arrive(arrive, train=train)
    assert line.section()["state"] == "review", line.section()
    return run


def late_photo_without_disc(line: Line, *, at: datetime = T0) -> None:
    """The arrival camera's image comes late and shows no tail disc: proof of a loss."""
    line.snapshot("B-cam", at + TRANSIT - timedelta(seconds=5), jpeg(disc=False, seed=2))


def alarm_run(line: Line, *, train: str = "2041", at: datetime = T0) -> int:
    """A train leaves A with four cars and reaches B with three and no tail disc: AB in alarm."""
    line.heartbeat_all(at - timedelta(seconds=20))
    line.read("A", [117, 118, 119, 120], at - timedelta(seconds=30))
    run = line.depart(at, train=train)
    arrive = at + TRANSIT
    line.heartbeat_all(arrive - timedelta(seconds=30))
    line.read("B", [117, 118, 119], arrive - timedelta(seconds=40))
    line.snapshot("B-cam", arrive - timedelta(seconds=5), jpeg(disc=False, seed=2))
    line.arrive(arrive, train=train)
    assert line.section()["state"] == "alarm", line.section()
    return run
