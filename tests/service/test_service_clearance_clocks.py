"""Device clocks that are wrong (an independent trial): evidence whose time cannot place it in
one run with certainty is a doubt that a person must look at — never a reason to free a
section, never proof for a run it may not belong to, never counted for two runs; and live
ingest and replay agree on it.

Every event reaches the server at its *real* time (``received``); a device whose clock is off
dates it wrongly (``occurred_at``). The server's clock is the test's (``tests/service/clock``).
"""

from __future__ import annotations

import random
from datetime import datetime, timedelta
from typing import Any

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import select
from sqlalchemy.orm import Session

from ingest.models import Snapshot
from service.clearance.models import AxleReading, Run
from service.replay import replay
from tests.service.clock import ServerClock, server_clock  # noqa: F401 (fixture)
from tests.service.conflictkit import decide, run_of
from tests.service.scenario import T0, Line, jpeg
from tests.service.test_service_clearance_groups import state

ARRIVE = T0 + timedelta(minutes=20)
SECOND = timedelta(seconds=1)


@pytest.fixture
def line(client: TestClient, server_clock: ServerClock) -> Line:  # noqa: F811
    return Line.clocked(client, server_clock)


def count(line: Line, device: str, axles: int, at: datetime, received: datetime) -> dict[str, Any]:
    return line.post(device, "axle_count", at, received=received, section="AB", axles=axles)


def short_train(line: Line, *, behind: timedelta, counted_late: bool = False) -> dict[str, Any]:
    """16 axles leave A, counted by a counter whose clock is ``behind``; 12 reach B (correct
    clocks), the tail disc is seen. ``counted_late``: the departure count reaches the server
    only after the arrival was decided."""
    line.keep_alive(T0 - 600 * SECOND, T0 - 20 * SECOND)
    line.depart(T0)
    passed = T0 + 15 * SECOND
    if not counted_late:
        assert count(line, "A-ac", 16, passed - behind, received=passed)["run"] is None
    line.keep_alive(T0 + 10 * SECOND, ARRIVE - 30 * SECOND)
    count(line, "B-ac", 12, ARRIVE - 20 * SECOND, received=ARRIVE - 20 * SECOND)
    line.snapshot("B-cam", ARRIVE - 5 * SECOND, jpeg(disc=True, seed=21))
    result = line.arrive(ARRIVE)
    if counted_late:
        late = ARRIVE + timedelta(minutes=2)
        assert count(line, "A-ac", 16, passed - behind, received=late)["run"] is None
    return result


def _blocking(line: Line, run: int, word: str) -> list[str]:
    decided = run_of(line, run)["decision"]
    assert decided["verdict"] != "complete", decided
    assert line.section()["state"] in ("review", "alarm"), line.section()
    named = [r for r in decided["reasons"] if word in r]
    assert named, decided["reasons"]
    return named


@pytest.mark.parametrize("minutes", [3, 8, 12, 15, 45])
def test_d2_departure_counter_clock_behind_does_not_free_a_short_train(
    line: Line, minutes: int
) -> None:
    """D2: the count dated 3–45 min before the departure fits no run's window (a count that
    early may be a previous train's: ``AttachmentWindows.adopt_before_departure``); it was
    received while the train held the section, so the run owes a person a look."""
    result = short_train(line, behind=timedelta(minutes=minutes))
    assert result["verdict"] != "complete", result
    assert line.section()["state"] == "review", line.section()
    named = _blocking(line, result["run"], "A-ac")
    assert "axle count" in named[0], named
    assert result["reasons"][0] == named[0], "the blocking reason comes first"


def test_d2_a_late_departure_count_with_its_clock_behind_puts_a_freed_section_to_review(
    line: Line,
) -> None:
    result = short_train(line, behind=timedelta(minutes=15), counted_late=True)
    assert result["verdict"] == "complete"  # nothing disagreed when the train arrived
    _blocking(line, result["run"], "A-ac")
    assert line.section()["state"] == "review"


def test_d2_a_counter_inside_the_window_still_proves_the_loss(line: Line) -> None:
    """A clock behind by less than the adoption window (seconds: clocks differ by that much)."""
    line.keep_alive(T0 - 600 * SECOND, T0 - 20 * SECOND)
    run = line.depart(T0)
    passed = T0 + 15 * SECOND
    assert count(line, "A-ac", 16, passed - 70 * SECOND, received=passed)["run"] == run
    line.keep_alive(T0 + 10 * SECOND, ARRIVE - 30 * SECOND)
    count(line, "B-ac", 12, ARRIVE - 20 * SECOND, received=ARRIVE - 20 * SECOND)
    result = line.arrive(ARRIVE)
    assert result["verdict"] == "incomplete", result
    assert line.section()["state"] == "alarm"


def _quick_follower(
    line: Line,
    dispatcher: dict[str, str],
    *,
    ahead: timedelta,
    photo_received: datetime,
    gap: timedelta,
) -> tuple[int, int, dict[str, Any]]:
    """2041 arrives at ARRIVE; its tail photo, taken 5 s before, is dated by a camera clock
    ``ahead`` and reaches the server at ``photo_received``; the dispatcher clears AB and 2043
    departs ``gap`` later, loses its tail on the way (no photo of its own)."""
    line.keep_alive(T0 - 600 * SECOND, T0 - 20 * SECOND)
    r1 = line.depart(T0)
    line.keep_alive(T0 + 10 * SECOND, ARRIVE - 30 * SECOND)
    taken = ARRIVE - 5 * SECOND
    photo_first = photo_received < ARRIVE
    if photo_first:
        line.snapshot("B-cam", taken + ahead, jpeg(disc=True, seed=21), received=photo_received)
    line.arrive(ARRIVE)
    if line.section()["state"] != "free":
        decide(line, dispatcher, r1)
    line.heartbeat_all(ARRIVE + gap - 10 * SECOND)
    r2 = line.depart(ARRIVE + gap, train="2043")
    if not photo_first:
        line.snapshot("B-cam", taken + ahead, jpeg(disc=True, seed=21), received=photo_received)
    second = ARRIVE + timedelta(minutes=21)
    line.heartbeat_all(second - 30 * SECOND)
    return r1, r2, line.arrive(second, train="2043")


@pytest.mark.parametrize(
    "ahead_s, received_s, gap_s",
    [(120, 90, 60), (120, -3, 60), (55, 90, 30), (290, 90, 60)],
    ids=str,
)
def test_d3_the_previous_trains_photo_does_not_decide_the_next_train(
    line: Line, dispatcher: dict[str, str], ahead_s: int, received_s: int, gap_s: int
) -> None:
    """D3: a photo dated after 2041's arrival (by up to the allowed skew) while 2043 holds
    the section may be either train's tail: it is ``present`` for neither. (55 s ahead, 2043
    gone 30 s after the arrival: the photo falls in 2041's 60 s after its arrival, and in
    2043's occupation — FIFO used to give it to 2043.)"""
    r1, r2, result = _quick_follower(
        line,
        dispatcher,
        ahead=timedelta(seconds=ahead_s),
        photo_received=ARRIVE + timedelta(seconds=received_s),
        gap=timedelta(seconds=gap_s),
    )
    assert result["run"] == r2 and result["verdict"] != "complete", result
    assert line.section()["state"] == "review", line.section()
    second = run_of(line, r2)
    assert second["evidence"]["tail"]["arrival"] is None, second["evidence"]
    assert any("snapshot" in r for r in second["decision"]["reasons"]), second["decision"]
    first = run_of(line, r1)
    assert first["evidence"]["tail"]["arrival"] is None, first["evidence"]
    assert first["decision"]["verdict"] != "complete", first["decision"]


def test_d7_an_arrival_interlocking_clock_ahead_is_no_conflict(
    line: Line, dispatcher: dict[str, str]
) -> None:
    """D7: B's interlocking dates the arrival 290 s ahead (the server accepts up to 300 s);
    2041 is complete and AB freed; 2043 departs a minute later by A's correct clock. By device
    time 2043 left before 2041 arrived, by the server's it did not: no conflict alarm — and
    the section is not freed by the tolerance either (2043 holds it)."""
    ahead = timedelta(seconds=290)
    line.keep_alive(T0 - 600 * SECOND, T0 - 20 * SECOND)
    line.depart(T0)
    line.keep_alive(T0 + 10 * SECOND, ARRIVE - 30 * SECOND)
    line.read("A", [117, 118, 119, 120], T0 - 30 * SECOND)
    line.read("B", [117, 118, 119, 120], ARRIVE - 40 * SECOND)
    line.snapshot("B-cam", ARRIVE - 5 * SECOND, jpeg(disc=True, seed=21))
    first = line.post(
        "B-ilk", "train_arrived", ARRIVE + ahead, received=ARRIVE, section="AB", train="2041"
    )
    assert first["verdict"] == "complete", first
    assert line.section()["state"] == "free"
    departed = line.post(
        "A-ilk", "train_departed", ARRIVE + 60 * SECOND, section="AB", train="2043"
    )
    assert not departed.get("conflict"), departed
    assert line.section()["state"] == "occupied", line.section()
    assert line.section()["run"]["id"] == departed["run"]


def test_arrival_count_dated_before_the_departure_does_not_free(line: Line) -> None:
    """B's counter is 40 min behind: the 12 axles it counts at the arrival are dated before
    the train departed. Fits no run by time; received while the train held AB: review."""
    behind = timedelta(minutes=40)
    line.keep_alive(T0 - 600 * SECOND, T0 - 20 * SECOND)
    line.depart(T0)
    count(line, "A-ac", 16, T0 + 15 * SECOND, received=T0 + 15 * SECOND)
    line.keep_alive(T0 + 10 * SECOND, ARRIVE - 30 * SECOND)
    counted = ARRIVE - 20 * SECOND
    assert count(line, "B-ac", 12, counted - behind, received=counted)["run"] is None
    line.snapshot("B-cam", ARRIVE - 5 * SECOND, jpeg(disc=True, seed=21))
    result = line.arrive(ARRIVE)
    assert result["verdict"] != "complete", result
    _blocking(line, result["run"], "B-ac")


# --- D10: one run per piece of evidence, the same in live ingest and in replay -------------

DEVICES_AT = {"A": ("A-ac", "A-cam"), "B": ("B-ac", "B-cam")}


def _traffic(seed: int) -> list[tuple[datetime, str, str, datetime, dict[str, Any]]]:
    """Trains both ways through AB with quick turnarounds; every device's clock off by its
    own amount (behind by any amount, ahead by at most 290 s): (received, device, kind,
    device time, fields), in the order the server receives them."""
    rng = random.Random(seed)
    offsets = {
        device: timedelta(seconds=rng.choice([-1500, -700, -90, 0, 0, 45, 120, 290]))
        for devices in DEVICES_AT.values()
        for device in devices
    }
    out: list[tuple[datetime, str, str, datetime, dict[str, Any]]] = []
    real = T0
    for number in range(rng.randint(3, 4)):
        origin, end = ("A", "B") if rng.random() < 0.5 else ("B", "A")
        train = f"20{41 + number}"
        transit = timedelta(minutes=rng.randint(4, 15))
        out.append((real, f"{origin}-ilk", "train_departed", real, {"train": train}))
        for device, at, axles in (
            (DEVICES_AT[origin][0], real + 20 * SECOND, 16),
            (DEVICES_AT[end][0], real + transit - 20 * SECOND, rng.choice([16, 16, 12])),
        ):
            out.append((at, device, "axle_count", at + offsets[device], {"axles": axles}))
        photo = real + transit - 5 * SECOND
        cam = DEVICES_AT[end][1]
        disc = rng.random() < 0.8
        delay = timedelta(seconds=rng.choice([0, 0, 70, 200]))
        out.append((photo + delay, cam, "snapshot", photo + offsets[cam], {"disc": disc}))
        out.append(
            (real + transit, f"{end}-ilk", "train_arrived", real + transit, {"train": train})
        )
        real += transit + timedelta(seconds=rng.choice([30, 60, 150, 400]))
    return sorted(out, key=lambda e: e[0])


def _play(line: Line, dispatcher: dict[str, str], events: list[Any]) -> None:
    line.keep_alive(T0 - 600 * SECOND, T0 - 20 * SECOND)
    for received, device, kind, at, fields in events:
        line.heartbeat_all(received - 10 * SECOND)
        if kind == "snapshot":
            line.snapshot(device, at, jpeg(disc=fields["disc"], seed=21), received=received)
            continue
        line.post(device, kind, at, received=received, section="AB", **fields)
        if kind == "train_arrived" and line.section()["state"] in ("review", "alarm"):
            run = line.section()["run"]["id"]
            decide(line, dispatcher, run)


def _photos(session: Session) -> dict[str, Any]:
    session.expire_all()
    runs = list(session.scalars(select(Run)))
    listed = [i for r in runs for i in (r.evidence or {}).get("snapshot_ids", [])]
    return {
        "listed_once": len(listed) == len(set(listed)),
        "photos": sorted(
            (s.device_id, s.occurred_at, s.verdict)
            for s in session.scalars(select(Snapshot).where(Snapshot.run_id.is_not(None)))
        ),
    }


@pytest.mark.parametrize("seed", range(4))
def test_d10_evidence_belongs_to_one_run_in_live_ingest_and_replay(
    line: Line, dispatcher: dict[str, str], session: Session, seed: int
) -> None:
    _play(line, dispatcher, _traffic(seed))
    live, photos = state(session), _photos(session)
    assert photos["listed_once"], "a photo is listed in two runs' evidence"
    for run in session.scalars(select(Run)):
        for reading in session.scalars(select(AxleReading).where(AxleReading.run_id == run.id)):
            assert reading.side in ("departure", "arrival")
    replay(session)
    session.commit()
    assert state(session) == live
    assert _photos(session) == photos
