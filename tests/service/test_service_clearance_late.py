"""Late evidence after a decision was shown (an independent trial: a late axle count that agreed
with the run turned a cleared section into ``alarm`` and backdated ``state_since`` before the
clear), the queue's headline (a reassuring reason shown above the blocking one), and the 409 of
a repeated decision (it did not say who decided, nor when)."""

from __future__ import annotations

from datetime import datetime, timedelta

import pytest
from fastapi.testclient import TestClient
from sqlalchemy.orm import Session

from tests.service.conflictkit import Broker, decide, run_of
from tests.service.reviewkit import TRANSIT, alarm_run, review_run
from tests.service.scenario import T0, Line, iso, jpeg
from tests.service.test_service_review_screen import login

ARRIVED = T0 + TRANSIT


def _cleared(line: Line, dispatcher: dict[str, str], kind: str) -> tuple[int, str]:
    run = alarm_run(line) if kind == "alarm" else review_run(line)
    decide(line, dispatcher, run)
    section = line.section()
    assert section["state"] == "free"
    return run, section["state_since"]


def _count(line: Line, session: Session, path: str, device: str, axles: int, at: datetime) -> None:
    if path == "http":
        line.post(device, "axle_count", at, section="AB", axles=axles)
    else:
        broker = Broker(session)
        broker.deliver((device, broker.body("axle_count", at, section="AB", axles=axles)))


PATHS = ["http", "broker"]


@pytest.mark.parametrize("path", PATHS)
@pytest.mark.parametrize("kind", ["alarm", "review"])
@pytest.mark.parametrize("device", ["A-ac", "B-ac"])
def test_a_late_count_that_agrees_changes_nothing(
    line: Line, session: Session, dispatcher: dict[str, str], path: str, kind: str, device: str
) -> None:
    """Both alarm_run and review_run leave A with 4 cars (16 axles); 3 resp. 4 reach B."""
    run, since = _cleared(line, dispatcher, kind)
    agreeing = 16 if device == "A-ac" else (12 if kind == "alarm" else 16)
    at = T0 + timedelta(seconds=5) if device == "A-ac" else ARRIVED - timedelta(seconds=20)
    _count(line, session, path, device, agreeing, at)
    section = line.section()
    assert section["state"] == "free", section
    assert section["state_since"] == since, section


@pytest.mark.parametrize("path", PATHS)
@pytest.mark.parametrize(
    ("kind", "axles", "state"), [("alarm", 8, "alarm"), ("review", 20, "review")]
)
def test_a_late_count_that_disagrees_asks_for_a_person_from_now(
    line: Line,
    session: Session,
    dispatcher: dict[str, str],
    path: str,
    kind: str,
    axles: int,
    state: str,
) -> None:
    run, since = _cleared(line, dispatcher, kind)
    _count(line, session, path, "B-ac", axles, ARRIVED - timedelta(seconds=20))
    section = line.section()
    assert section["state"] == state, section
    assert section["state_since"] > since, (section, since)  # never before the clear
    assert any(str(axles) in r for r in run_of(line, run)["decision"]["reasons"])


def test_a_kept_blocked_section_stays_blocked_on_agreeing_late_evidence(
    line: Line, dispatcher: dict[str, str]
) -> None:
    run = alarm_run(line)
    decide(line, dispatcher, run, "keep_blocked")
    since = line.section()["state_since"]
    line.post("A-ac", "axle_count", T0 + timedelta(seconds=5), section="AB", axles=16)
    assert line.section()["state"] == "blocked" and line.section()["state_since"] == since


MISMATCH = "arrival reported train 2014, departure train 2041"


def _queue_line(client: TestClient, run: int) -> str:
    page = client.get("/review").text
    queue = page.split('id="queue"')[1].split("</table>")[0]
    row = queue.split(f'data-run="{run}"', 1)[1].split("</tr>")[0]
    headline: str = row.split('class="muted">')[1].split("</div>")[0]
    return headline


def test_the_queue_headline_is_the_blocking_reason(
    line: Line, client: TestClient, session: Session
) -> None:
    """A train-number mismatch with every item agreeing: the headline is the mismatch."""
    line.heartbeat_all(T0 - timedelta(seconds=20))
    line.post("A-ac", "axle_count", T0 - timedelta(seconds=10), section="AB", axles=16)
    run = line.depart(T0, train="2041")
    line.heartbeat_all(ARRIVED - timedelta(seconds=30))
    line.post("B-ac", "axle_count", ARRIVED - timedelta(seconds=20), section="AB", axles=16)
    line.snapshot("B-cam", ARRIVED - timedelta(seconds=5), jpeg(disc=True, seed=3))
    line.arrive(ARRIVED, train="2014")
    decision = run_of(line, run)["decision"]
    assert decision["verdict"] == "undetermined"
    assert decision["reasons"][0] == MISMATCH, decision
    login(client, session)
    assert _queue_line(client, run) == MISMATCH


def test_the_queue_headline_of_a_complete_run_in_an_alarmed_section_names_the_alarm(
    line: Line, client: TestClient, session: Session, dispatcher: dict[str, str]
) -> None:
    """2041 is cleared, 2043 holds AB; a late photo proves 2041 lost cars: AB in alarm while
    2043 arrives complete. The queue must not read "tail disc present" for AB."""
    r1 = review_run(line)
    decide(line, dispatcher, r1)
    start = ARRIVED + timedelta(minutes=5)
    line.heartbeat_all(start)
    r2 = line.depart(start, train="2043")
    line.snapshot("B-cam", ARRIVED - timedelta(seconds=5), jpeg(disc=False, seed=2))
    assert line.section()["state"] == "alarm"
    line.heartbeat_all(start + TRANSIT - timedelta(seconds=30))
    line.snapshot("B-cam", start + TRANSIT - timedelta(seconds=5), jpeg(disc=True, seed=21))
    assert line.arrive(start + TRANSIT, train="2043")["verdict"] == "complete"
    login(client, session, "ivan")
    headline = _queue_line(client, r2)
    assert "tail disc" in headline and f"run {r1}" in headline, headline
    assert "present" not in headline, headline


def test_a_repeated_decision_names_who_decided_and_when(
    line: Line, dispatcher: dict[str, str]
) -> None:
    run = alarm_run(line)
    first = decide(line, dispatcher, run, "keep_blocked")
    again = decide(line, dispatcher, run, "keep_blocked", status=409)
    when = first["audit"]["recorded_at"]
    assert "olena" in again["detail"] and when in again["detail"], again
    assert iso(T0) not in again["detail"]
