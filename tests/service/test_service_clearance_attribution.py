"""A later train's tail photo must never decide an earlier run (an independent trial: it turned
an already decided run ``complete``). Evidence attaches to the run whose time it belongs to, or
to none, in every order of arrival of the events."""

from __future__ import annotations

from datetime import timedelta

from tests.conftest import ADMIN
from tests.service.conflictkit import decide, depart, run_of
from tests.service.reviewkit import TRANSIT, review_run
from tests.service.scenario import T0, Line, jpeg

ARRIVED = T0 + TRANSIT


def _cleared_undetermined(line: Line, dispatcher: dict[str, str]) -> int:
    """2041 arrives without a tail photo (undetermined); the dispatcher clears AB."""
    r1 = review_run(line)
    decide(line, dispatcher, r1)
    assert line.section()["state"] == "free"
    return r1


def _snapshot_run(line: Line, snapshot: int) -> int | None:
    meta = line.client.get(f"/api/v1/snapshots/{snapshot}/meta", headers=ADMIN).json()
    run: int | None = meta["run_id"]
    return run


def _unchanged(line: Line, r1: int) -> None:
    first = run_of(line, r1)
    assert first["decision"]["verdict"] == "undetermined", first
    assert first["evidence"]["snapshot_ids"] == [], first


def test_the_next_trains_photo_posted_before_its_departure_is_not_the_earlier_runs(
    line: Line, dispatcher: dict[str, str]
) -> None:
    r1 = _cleared_undetermined(line, dispatcher)
    line.heartbeat_all(ARRIVED + timedelta(minutes=2))
    photo = line.snapshot("B-cam", ARRIVED + timedelta(minutes=6), jpeg(disc=True, seed=21))
    assert photo["run"] != r1, photo
    _unchanged(line, r1)
    r2 = depart(line, ARRIVED + timedelta(minutes=3), "2043")["run"]
    assert _snapshot_run(line, photo["snapshot"]) == r2
    _unchanged(line, r1)
    answer = line.arrive(ARRIVED + timedelta(minutes=7), train="2043")
    assert answer["run"] == r2 and answer["verdict"] == "complete", answer
    assert run_of(line, r2)["evidence"]["snapshot_ids"] == [photo["snapshot"]]
    _unchanged(line, r1)


def test_a_photo_after_the_arrival_with_no_train_behind_decides_nothing(
    line: Line, dispatcher: dict[str, str]
) -> None:
    r1 = review_run(line)
    line.heartbeat_all(ARRIVED + timedelta(minutes=2))
    photo = line.snapshot("B-cam", ARRIVED + timedelta(minutes=5), jpeg(disc=True, seed=21))
    assert photo["run"] is None, photo
    _unchanged(line, r1)
    assert line.section()["state"] == "review"


def test_the_photo_of_a_train_that_departed_into_the_uncleared_section_is_its_own(
    line: Line, dispatcher: dict[str, str]
) -> None:
    r1 = review_run(line)
    r2 = depart(line, ARRIVED + timedelta(minutes=1), "2043")["run"]
    line.heartbeat_all(ARRIVED + timedelta(minutes=2))
    photo = line.snapshot("B-cam", ARRIVED + timedelta(minutes=4), jpeg(disc=True, seed=21))
    assert photo["run"] == r2, photo
    _unchanged(line, r1)
    assert line.section()["state"] == "alarm"


def test_a_late_departure_takes_its_photo_back_from_the_earlier_run(
    line: Line, dispatcher: dict[str, str]
) -> None:
    """The photo is dated 30 s after 2041's arrival (inside its grace); then 2043's departure,
    dated before the photo, arrives late: the photo is 2043's, and 2041 is decided again."""
    r1 = review_run(line)
    decide(line, dispatcher, r1)
    line.heartbeat_all(ARRIVED)
    photo = line.snapshot("B-cam", ARRIVED + timedelta(seconds=30), jpeg(disc=True, seed=21))
    r2 = depart(line, ARRIVED + timedelta(seconds=10), "2043")["run"]
    assert _snapshot_run(line, photo["snapshot"]) == r2
    _unchanged(line, r1)
    answer = line.arrive(ARRIVED + timedelta(seconds=40), train="2043")
    assert answer["run"] == r2, answer
    assert run_of(line, r2)["evidence"]["snapshot_ids"] == [photo["snapshot"]]


def _previous_reads_then_a_short_consist(line: Line) -> dict[str, object]:
    """Cars 117–120 are read at A 3 min before 2043 departs (a previous train, a shunting
    move); 2043 itself is read as 117, 118 just before its departure, and reaches B whole."""
    line.heartbeat_all(T0 - timedelta(minutes=4))
    line.read("A", [117, 118, 119, 120], T0 - timedelta(minutes=3))
    line.heartbeat_all(T0 - timedelta(seconds=20))
    line.read("A", [117, 118], T0 - timedelta(seconds=40))
    line.depart(T0, train="2043")
    line.heartbeat_all(ARRIVED - timedelta(seconds=30))
    line.read("B", [117, 118], ARRIVED - timedelta(seconds=40))
    line.snapshot("B-cam", ARRIVED - timedelta(seconds=5), jpeg(disc=True, seed=21))
    return line.arrive(ARRIVED, train="2043")


def test_reads_minutes_before_a_departure_are_a_doubt_not_the_trains_consist(
    line: Line,
) -> None:
    """An independent trial: reads dated 3 min before the departure were adopted into the run
    (a 10 min window), and the train was shown incomplete — a false alarm. They could be the
    previous train's or this one's with a clock behind: a person must look, nothing proven."""
    answer = _previous_reads_then_a_short_consist(line)
    assert answer["verdict"] == "undetermined", answer
    assert line.section()["state"] == "review", line.section()
    decided = run_of(line, answer["run"])["decision"]
    assert not any("lacks" in r for r in decided["reasons"]), decided["reasons"]
    doubts = [r for r in decided["reasons"] if "A-ir" in r and "cannot be placed" in r]
    assert len(doubts) == 4, decided["reasons"]


def test_reads_seconds_before_a_departure_are_the_trains(line: Line) -> None:
    """A reader before the departure signal, or clocks seconds apart: still the run's."""
    line.heartbeat_all(T0 - timedelta(seconds=70))
    line.read("A", [117, 118], T0 - timedelta(seconds=55))
    line.depart(T0, train="2043")
    line.heartbeat_all(ARRIVED - timedelta(seconds=30))
    line.read("B", [117], ARRIVED - timedelta(seconds=40))
    line.snapshot("B-cam", ARRIVED - timedelta(seconds=5), jpeg(disc=True, seed=21))
    answer = line.arrive(ARRIVED, train="2043")
    assert answer["verdict"] == "incomplete", answer
