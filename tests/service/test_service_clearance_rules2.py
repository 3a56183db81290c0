"""Defects an independent trial found in the clearance rules (README and spec only): an arrival
out of a section nobody saw a train enter, a late departure taken for the sweep train or not
seen as a conflict, a state dated in the future, a departure photo without the tail disc that
did not contradict an arrival photo with it, a conflict's headline, and a run whose arrival
never comes with no train behind it (the dispatcher's action was a dead 409 for ever)."""

from __future__ import annotations

from datetime import datetime, timedelta

from fastapi.testclient import TestClient
from sqlalchemy.orm import Session

from service.clearance.overdue import OVERDUE
from service.replay import replay
from tests.conftest import ADMIN
from tests.service.clock import ServerClock, server_clock  # noqa: F401 (fixture)
from tests.service.conflictkit import arrive, decide, depart, resolve_all, run_of
from tests.service.reviewkit import TRANSIT, review_run
from tests.service.scenario import T0, Line, jpeg
from tests.service.test_service_replay import snapshot_of_state
from tests.service.test_service_review_screen import login

ARRIVED = T0 + TRANSIT
CARS = [117, 118, 119, 120]


def _queue_line(client: TestClient, run: int) -> str:
    """The headline the review queue shows for the section whose current run is ``run``."""
    page = client.get("/review").text
    queue = page.split('id="queue"')[1].split("</table>")[0]
    row = queue.split(f'data-run="{run}"', 1)[1].split("</tr>")[0]
    headline: str = row.split('class="muted">')[1].split("</div>")[0]
    return headline


def _complete_run(line: Line, *, train: str = "2041", at: datetime = T0) -> int:
    """Four cars leave A and reach B, the arrival camera sees the tail disc: AB is free."""
    line.heartbeat_all(at - timedelta(seconds=20))
    line.read("A", CARS, at - timedelta(seconds=30))
    run = line.depart(at, train=train)
    line.heartbeat_all(at + TRANSIT - timedelta(seconds=30))
    line.read("B", CARS, at + TRANSIT - timedelta(seconds=40))
    line.snapshot("B-cam", at + TRANSIT - timedelta(seconds=5), jpeg(disc=True, seed=3))
    line.arrive(at + TRANSIT, train=train)
    assert line.section()["state"] == "free", line.section()
    return run


# -- D4: a train arriving out of a section nobody saw it enter -------------------------------


def test_an_arrival_nobody_saw_enter_puts_the_section_in_review(
    line: Line, client: TestClient, session: Session, dispatcher: dict[str, str]
) -> None:
    line.heartbeat_all(T0 - timedelta(seconds=20))
    answer = arrive(line, ARRIVED, "2041")
    assert answer["run"] is None and "kept" in answer["warning"], answer  # for a late departure
    section = line.section()
    assert section["state"] == "review", section
    assert section["run"]["departure_seen"] is False, section
    doubt = section["run"]["decision"]["reasons"][0]
    assert "2041" in doubt and "AB" in doubt and "nobody saw it enter" in doubt, doubt
    login(client, session, "ivan")
    assert _queue_line(client, section["run"]["id"]) == doubt
    resolve_all(line, dispatcher, [section["run"]["id"]])  # a person looked, and cleared it


def test_the_late_departure_explains_the_arrival_and_the_doubt_goes(
    line: Line, client: TestClient, session: Session
) -> None:
    line.heartbeat_all(T0 - timedelta(seconds=20))
    arrive(line, ARRIVED, "2041")
    unseen = line.section()["run"]["id"]
    run = depart(line, T0, "2041")
    assert "conflict" not in run, run  # the departure the arrival waited for, not a second train
    assert run_of(line, run["run"])["arrived_at"] is not None
    section = line.section()
    assert section["last_run_id"] == run["run"] and section["conflict_runs"] == [], section
    assert section["state"] == "review"  # no tail photo: the run's own doubt, not the unseen one
    assert not any("nobody saw" in r for r in section["run"]["decision"]["reasons"]), section
    assert line.client.get(f"/api/v1/runs/{unseen}", headers=ADMIN).status_code == 404
    before = snapshot_of_state(client)
    counts = replay(session)
    session.commit()
    assert counts["failed"] == 0 and snapshot_of_state(client) == before


def test_an_arrival_nobody_saw_enter_while_the_section_is_in_review_waits_behind(
    line: Line, dispatcher: dict[str, str]
) -> None:
    r1 = review_run(line)
    arrive(line, ARRIVED + timedelta(minutes=25), "2043")
    section = line.section()
    assert section["last_run_id"] == r1 and len(section["conflict_runs"]) == 1, section
    unseen = section["conflict_runs"][0]
    decide(line, dispatcher, r1)
    assert line.section()["state"] == "review"  # never free while the doubt waits
    resolve_all(line, dispatcher, [unseen])


# -- D5: a late departure is not the sweep train -----------------------------------------------


def test_a_late_departure_dated_while_the_swept_train_was_inside_is_not_the_sweep(
    line: Line, dispatcher: dict[str, str]
) -> None:
    r1 = review_run(line)
    decide(line, dispatcher, r1, "sweep")
    assert line.section()["state"] == "awaiting_sweep"
    late = depart(line, T0 + timedelta(minutes=10), "2043")  # 2041 was still in AB then
    assert late.get("sweep") is not True and late["conflict"] is True, late
    assert "before" in late["detail"] and "sweep" in late["detail"], late
    line.heartbeat_all(ARRIVED + timedelta(minutes=10))
    line.read("B", CARS, ARRIVED + timedelta(minutes=10))
    line.snapshot("B-cam", ARRIVED + timedelta(minutes=11), jpeg(disc=True, seed=5))
    arrive(line, ARRIVED + timedelta(minutes=11, seconds=5), "2043")
    assert line.section()["state"] not in ("free", "occupied"), line.section()
    assert run_of(line, r1)["cleared_by"] is None
    assert run_of(line, late["run"])["sweep"] is False


def test_a_sweep_train_departing_after_the_arrival_is_still_the_sweep(
    line: Line, dispatcher: dict[str, str]
) -> None:
    r1 = review_run(line)
    decide(line, dispatcher, r1, "sweep")
    sweep = depart(line, ARRIVED + timedelta(minutes=5), "2043")
    assert sweep["sweep"] is True and sweep["sweep_of"] == r1, sweep


# -- D6: a late departure dated before the current train's ------------------------------------


def test_a_late_departure_dated_before_the_current_trains_is_a_conflict(
    line: Line, client: TestClient, session: Session, dispatcher: dict[str, str]
) -> None:
    r1 = _complete_run(line)
    late = depart(line, T0 - timedelta(minutes=5), "2039")  # it was in AB when 2041 left A
    assert late["conflict"] is True, late
    assert "2041" in late["detail"] and "2039" in late["detail"], late
    assert line.section()["state"] == "alarm", line.section()
    assert run_of(line, r1)["decision"]["verdict"] != "complete"
    login(client, session, "ivan")
    headline = _queue_line(client, late["run"])
    assert "2039" in headline and "2041" in headline, headline  # D11: the alarm, named
    resolve_all(line, dispatcher, [late["run"]])


# -- D8: a state is never dated after the server's now -----------------------------------------


def test_state_since_is_never_in_the_future(
    client: TestClient,
    server_clock: ServerClock,  # noqa: F811
) -> None:
    line = Line.clocked(client, server_clock)
    line.heartbeat_all(T0 - timedelta(seconds=20))
    # the interlocking's clock runs 4 minutes ahead (inside the allowed skew)
    line.post("A-ilk", "train_departed", T0 + timedelta(minutes=4), received=T0, section="AB",
              train="2041")  # fmt: skip
    assert line.section()["state"] == "occupied"
    assert line.section()["state_since"] == "2026-11-23T10:00:00Z", line.section()
    line.heartbeat_all(ARRIVED - timedelta(seconds=30))
    line.post("B-ilk", "train_arrived", ARRIVED + timedelta(minutes=4), received=ARRIVED,
              section="AB", train="2041")  # fmt: skip
    assert line.section()["state"] == "review"
    assert line.section()["state_since"] == "2026-11-23T10:20:00Z", line.section()


# -- D9: the departure image without the disc contradicts the arrival image with it ------------


def test_a_departure_photo_without_the_disc_contradicts_an_arrival_photo_with_it(
    line: Line,
) -> None:
    line.heartbeat_all(T0 - timedelta(seconds=20))
    line.read("A", CARS, T0 - timedelta(seconds=30))
    shot = line.snapshot("A-cam", T0 - timedelta(seconds=10), jpeg(disc=False, seed=2))
    assert shot["verdict"] == "absent", shot
    line.depart(T0)
    line.heartbeat_all(ARRIVED - timedelta(seconds=30))
    line.read("B", CARS, ARRIVED - timedelta(seconds=40))
    line.snapshot("B-cam", ARRIVED - timedelta(seconds=5), jpeg(disc=True, seed=3))
    answer = line.arrive(ARRIVED)
    assert answer["verdict"] == "undetermined", answer
    assert "departure image" in answer["reasons"][0], answer
    assert line.section()["state"] == "review"


# -- D11: a conflict's headline is the alarm ---------------------------------------------------


def test_the_headline_of_a_section_with_two_trains_is_the_conflict(
    line: Line, client: TestClient, session: Session
) -> None:
    r1 = review_run(line)
    depart(line, ARRIVED + timedelta(minutes=2), "2043")
    assert line.section()["state"] == "alarm"
    login(client, session, "ivan")
    headline = _queue_line(client, r1)
    assert "2043" in headline and "departed into section AB" in headline, headline


# -- spec gap: a run whose arrival never comes, with no train behind it -------------------------


def test_a_silent_section_lets_the_dispatcher_block_a_train_that_never_arrived(
    client: TestClient,
    session: Session,
    server_clock: ServerClock,  # noqa: F811
) -> None:
    line = Line.clocked(client, server_clock)
    dispatcher = {"Authorization": f"Bearer {login(client, session, 'ivan')}"}
    line.heartbeat_all(T0 - timedelta(seconds=20))
    run = line.depart(T0)
    server_clock.set(T0 + timedelta(minutes=10))
    assert "has not arrived" in decide(line, dispatcher, run, "keep_blocked", 409)["detail"]
    late = T0 + OVERDUE.silent_after - timedelta(minutes=5)  # the section speaks again
    line.post("B-ac", "axle_count", late, section="AB", axles=16)
    server_clock.set(T0 + OVERDUE.silent_after + timedelta(minutes=1))
    decide(line, dispatcher, run, "keep_blocked", 409)  # silent only 6 minutes
    server_clock.set(late + OVERDUE.silent_after + timedelta(minutes=1))
    assert line.section()["state"] == "occupied"  # never cleared, nor blocked, by itself
    page = client.get(f"/review?run={run}").text
    assert 'value="keep_blocked"' in page and 'value="clear"' not in page
    assert "has not arrived" in _queue_line(client, run)
    refused = decide(line, dispatcher, run, "clear", 409)  # blocked first, then cleared
    assert "keep it blocked first" in refused["detail"], refused
    blocked = decide(line, dispatcher, run, "keep_blocked")
    assert blocked["state"] == "blocked"
    assert blocked["audit"]["evidence"]["arrival_missing"].startswith("no arrival"), blocked
    assert decide(line, dispatcher, run, "clear")["state"] == "free"
    assert [o["action"] for o in run_of(line, run)["overrides"]] == ["keep_blocked", "clear"]
    before = snapshot_of_state(client)
    counts = replay(session)
    session.commit()
    assert counts["refused_actions"] == 0 and snapshot_of_state(client) == before, counts
