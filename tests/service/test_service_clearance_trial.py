"""Three safety holes an independent trial found: a section shown ``free`` although its evidence
belongs to another train, contradicts itself, or the arrival is dated before the departure."""

from __future__ import annotations

from datetime import datetime, timedelta
from typing import Any

from tests.conftest import ADMIN
from tests.service.scenario import T0, Line, jpeg

NOW = T0 + timedelta(hours=1)
ARRIVE = T0 + timedelta(minutes=20)


def run_of(line: Line, run: int) -> dict[str, Any]:
    answer = line.client.get(f"/api/v1/runs/{run}", headers=ADMIN)
    assert answer.status_code == 200, answer.text
    result: dict[str, Any] = answer.json()
    return result


def cleared_r1(line: Line, dispatcher: dict[str, str]) -> int:
    """r1 departs at −120 s and arrives at −90 s without a photo; the dispatcher clears it."""
    line.heartbeat_all(NOW - timedelta(seconds=130))
    r1 = line.depart(NOW - timedelta(seconds=120), train="2041")
    assert line.arrive(NOW - timedelta(seconds=90), train="2041")["verdict"] == "undetermined"
    cleared = line.client.post(
        f"/api/v1/runs/{r1}/decision",
        json={"action": "clear", "reason": "walker saw the tail disc"},
        headers=dispatcher,
    )
    assert cleared.status_code == 200, cleared.text
    assert line.section()["state"] == "free"
    return r1


def test_a_photo_dated_inside_the_previous_run_does_not_free_the_next(
    line: Line, dispatcher: dict[str, str]
) -> None:
    r1 = cleared_r1(line, dispatcher)
    line.heartbeat_all(NOW - timedelta(seconds=5))
    r2 = line.depart(NOW, train="2043")
    posted = line.snapshot("B-cam", NOW - timedelta(seconds=100), jpeg(disc=True, seed=21))
    assert posted.get("run") != r2, posted
    result = line.arrive(NOW + timedelta(seconds=30), train="2043")
    assert result["verdict"] == "undetermined", result
    assert "no arrival image of the last car" in result["reasons"]
    assert line.section()["state"] == "review"
    assert run_of(line, r2)["evidence"]["snapshot_ids"] == []
    assert posted["snapshot"] in run_of(line, r1)["evidence"]["snapshot_ids"]


def test_a_late_absent_photo_of_the_cleared_run_raises_the_alarm(
    line: Line, dispatcher: dict[str, str]
) -> None:
    """Late evidence of incompleteness on a cleared run turns the section into ``alarm``
    (clearance.md, Runs), even while the next train holds it."""
    r1 = cleared_r1(line, dispatcher)
    line.heartbeat_all(NOW - timedelta(seconds=5))
    r2 = line.depart(NOW, train="2043")
    posted = line.snapshot("B-cam", NOW - timedelta(seconds=100), jpeg(disc=False, seed=2))
    assert posted["run"] == r1, posted
    assert run_of(line, r1)["decision"]["verdict"] == "incomplete"
    assert line.section()["state"] == "alarm"
    line.snapshot("B-cam", NOW + timedelta(seconds=25), jpeg(disc=True, seed=21))
    # Dated 115 s after r1's arrival, the photo may be r1's tail by a camera clock ahead
    # (allowed up to 300 s): it proves nothing for r2 (test_service_clearance_clocks, D3).
    assert line.arrive(NOW + timedelta(seconds=30), train="2043")["verdict"] == "undetermined"
    assert run_of(line, r2)["evidence"]["snapshot_ids"] != [posted["snapshot"]]
    assert line.section()["state"] == "alarm"  # r1's lost cars: a person must look


def count(line: Line, device: str, axles: int, at: datetime) -> None:
    line.post(device, "axle_count", at, section="AB", axles=axles)


def arrive_with_disc(line: Line) -> dict[str, Any]:
    line.heartbeat_all(ARRIVE - timedelta(seconds=30))
    line.snapshot("B-cam", ARRIVE - timedelta(seconds=5), jpeg(disc=True, seed=21))
    return line.arrive(ARRIVE)


def depart(line: Line) -> None:
    line.heartbeat_all(T0 - timedelta(seconds=20))
    line.depart()


def test_an_arrival_count_proving_a_loss_is_not_overwritten(line: Line) -> None:
    depart(line)
    count(line, "A-ac", 48, T0 + timedelta(seconds=10))
    count(line, "B-ac", 40, ARRIVE - timedelta(seconds=20))
    count(line, "B-ac", 48, ARRIVE - timedelta(seconds=15))
    result = arrive_with_disc(line)
    assert result["verdict"] == "incomplete", result
    assert any("40 axles arrived of 48" in r for r in result["reasons"]), result
    assert line.section()["state"] == "alarm"


def test_a_departure_count_proving_a_loss_is_not_overwritten(line: Line) -> None:
    depart(line)
    count(line, "A-ac", 48, T0 + timedelta(seconds=10))
    count(line, "A-ac", 40, T0 + timedelta(seconds=15))
    count(line, "B-ac", 40, ARRIVE - timedelta(seconds=20))
    result = arrive_with_disc(line)
    assert result["verdict"] == "incomplete", result
    assert any("40 axles arrived of 48" in r for r in result["reasons"]), result


def test_two_departure_counts_that_prove_nothing_are_a_contradiction(line: Line) -> None:
    depart(line)
    count(line, "A-ac", 48, T0 + timedelta(seconds=10))
    count(line, "A-ac", 40, T0 + timedelta(seconds=15))
    count(line, "B-ac", 48, ARRIVE - timedelta(seconds=20))
    result = arrive_with_disc(line)
    assert result["verdict"] == "undetermined", result
    assert any("departure" in r and "40" in r and "48" in r for r in result["reasons"]), result
    assert line.section()["state"] == "review"


def test_an_absent_photo_is_not_overwritten_by_a_present_one(line: Line) -> None:
    depart(line)
    line.heartbeat_all(ARRIVE - timedelta(seconds=30))
    absent = line.snapshot("B-cam", ARRIVE - timedelta(seconds=8), jpeg(disc=False, seed=2))
    assert absent["verdict"] == "absent" and absent["score"] > 0.8, absent
    line.snapshot("B-cam", ARRIVE - timedelta(seconds=5), jpeg(disc=True, seed=21))
    result = line.arrive(ARRIVE)
    assert result["verdict"] == "incomplete", result
    assert line.section()["state"] == "alarm"


def test_an_arrival_dated_before_its_departure_needs_a_person(line: Line) -> None:
    depart(line)
    line.heartbeat_all(T0 - timedelta(seconds=10))
    line.snapshot("B-cam", T0 + timedelta(seconds=5), jpeg(disc=True, seed=21))
    result = line.arrive(T0 - timedelta(seconds=60))
    assert result["verdict"] == "undetermined", result
    assert any("before" in r and "departure" in r for r in result["reasons"]), result
    assert line.section()["state"] == "review"
    # Late evidence re-decides the run: the contradiction in its times must stay.
    line.post("B-ac", "axle_count", T0 + timedelta(seconds=6), section="AB", axles=48)
    assert line.section()["state"] == "review"
