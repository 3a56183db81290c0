"""The independent passage-liveness trial, continued: *when* the train passed. A device at
either end that sent nothing must have been heard around every credible instant of the
departure and the arrival (when the server received each, and when its device dated it), so
reports that reach the server late, out of order, or a journey that is very short or follows
another train closely, still name the silent device.

The kit (``Plan``, the healthy line) is ``tests/service/livenesskit.py``.
"""

from __future__ import annotations

import pytest
from fastapi.testclient import TestClient
from sqlalchemy.orm import Session

from tests.service.clock import ServerClock, server_clock  # noqa: F401 (fixture)
from tests.service.livenesskit import (
    ARRIVE,
    ENDS,
    M,
    Plan,
    S,
    assert_free,
    assert_review_naming,
    decision,
    evidence,
    replays_the_same,
)
from tests.service.scenario import T0, Line


@pytest.fixture
def line(client: TestClient, server_clock: ServerClock) -> Line:  # noqa: F811
    return Line.clocked(client, server_clock)


def test_departure_reader_silent_as_the_train_leaves(line: Line, session: Session) -> None:
    """A-ir was last heard 50 s before the departure and not again until after the arrival;
    the train's rear passes A's devices after the interlocking reports the departure (A-ac
    counts it 15 s later; departure-side evidence belongs to the run up to 10 min after it).
    A-ir reported nothing: its departure consist is missing, it was silent 65 s when the tail
    passed.

    Found by the trial (fixed since): it was complete/free, A-ir not named: the departure end
    was judged only over the 10 min *before* the departure's receipt (passage.departure_window),
    though the service adopts departure-side evidence up to 10 min after it (AttachmentWindows).
    """
    plan = Plan(line)
    plan.beat(set(ENDS) - {"A-ir"}, T0 - 10 * M, ARRIVE + 30 * S)
    plan.beat(["A-ir"], T0 - 10 * M, T0 - 50 * S)
    plan.beat(["A-ir"], ARRIVE + 30 * S, ARRIVE + 30 * S)
    evidence(plan, skip=("A-ir",))
    run = plan.play()["depart"]["run"]
    assert_review_naming(line, run, "A-ir")
    replays_the_same(line, session)


@pytest.mark.parametrize(("late_min", "silent_min"), [(30, 5), (8, 2)], ids=["30 min", "8 min"])
def test_arrival_reaching_the_server_late(
    line: Line, session: Session, late_min: int, silent_min: int
) -> None:
    """B's interlocking link is down: the arrival (dated ARRIVE) reaches the server ``late_min``
    late. B-ir was silent from T0+``silent_min`` min to ARRIVE+5 min (the train passed it at
    ARRIVE-40 s), then heard again as a live line.

    Found by the trial (fixed since), 30 min late: it was complete/free: the arrival end was
    judged only over the 10 min before the arrival's receipt (believed_lateness), though the
    section was held from T0 and the arrival itself is dated 30 min before its receipt. The
    8 min case, within the believed lateness, is the control.
    """
    plan = Plan(line)
    late = ARRIVE + late_min * M
    plan.beat(set(ENDS) - {"B-ir", "B-ilk"}, T0 - 10 * M, late + 30 * S)
    plan.beat(["B-ilk"], T0 - 10 * M, T0 + 5 * M)
    plan.beat(["B-ir"], T0 - 10 * M, T0 + silent_min * M)
    plan.beat(["B-ir"], ARRIVE + 5 * M, late + 30 * S)
    evidence(plan, skip=("B-ir",))
    plan.items = [i for i in plan.items if i[2] != "arrive"]
    plan.post(
        "B-ilk", "train_arrived", ARRIVE, received=late, label="arrive", section="AB", train="2041"
    )
    run = plan.play()["depart"]["run"]
    assert_review_naming(line, run, "B-ir")
    replays_the_same(line, session)


def test_departure_reaching_the_server_after_the_arrival(line: Line, session: Session) -> None:
    """A's interlocking link is down: the departure (dated T0) reaches the server after the
    arrival (30 min journey). A-ir was silent from T0-5 min to T0+10 min (around the real
    departure), heard before and after.

    Found by the trial (fixed since): it was complete/free once the departure came: the
    departure end was judged over the 10 min before the arrival's receipt (T0+20..T0+30), not
    around T0.
    """
    arrive = T0 + 30 * M
    plan = Plan(line)
    plan.beat(set(ENDS) - {"A-ir", "A-ilk"}, T0 - 10 * M, arrive + 2 * M)
    plan.beat(["A-ir"], T0 - 10 * M, T0 - 5 * M)
    plan.beat(["A-ir"], T0 + 10 * M, arrive + 2 * M)
    evidence(plan, arrive, skip=("A-ir",))
    plan.items = [i for i in plan.items if i[2] != "depart"]
    plan.post(
        "A-ilk",
        "train_departed",
        T0,
        received=arrive + M,
        label="depart",
        section="AB",
        train="2041",
    )
    run = plan.play()["depart"]["run"]
    assert_review_naming(line, run, "A-ir")
    replays_the_same(line, session)


@pytest.mark.parametrize("last_heard_s", [300, 50])
def test_a_very_short_journey(line: Line, session: Session, last_heard_s: int) -> None:
    """The train is in AB for 30 s; B-ir was last heard ``last_heard_s`` before the departure
    and never again: silent longer than 60 s by the arrival."""
    arrive = T0 + 30 * S
    plan = Plan(line)
    plan.beat(set(ENDS) - {"B-ir"}, T0 - 10 * M, arrive)
    plan.beat(["B-ir"], T0 - last_heard_s * S, T0 - last_heard_s * S)
    plan.post("B-ir", "heartbeat", T0 - 10 * M)
    evidence(plan, arrive, skip=("B-ir",))
    run = plan.play()["depart"]["run"]
    assert_review_naming(line, run, "B-ir")
    replays_the_same(line, session)


def test_back_to_back_trains_reads_of_the_first_do_not_keep_the_reader_alive(
    line: Line, session: Session
) -> None:
    """2041 is read at B and freed; B-ir dies right after. 2043 departs 6 min later and
    arrives 6 min after that: B-ir was silent through its passage."""
    plan = Plan(line)
    plan.beat(set(ENDS) - {"B-ir"}, T0 - 10 * M, ARRIVE + 30 * S)
    plan.beat(["B-ir"], T0 - 10 * M, ARRIVE - 45 * S)
    evidence(plan)
    first = plan.play()["depart"]["run"]
    assert_free(line, first)
    plan2 = Plan(line)
    plan2.beat(set(ENDS) - {"B-ir"}, ARRIVE + 31 * S, ARRIVE + 13 * M)
    evidence(plan2, ARRIVE + 12 * M, depart=ARRIVE + 6 * M, train="2043", skip=("B-ir",))
    second = plan2.play()["depart"]["run"]
    named = assert_review_naming(line, second, "B-ir")
    assert "silent" in named[0], decision(line, second)
    replays_the_same(line, session)


# --- devices registered or decommissioned ---------------------------------------------------


def test_departure_camera_silent_when_the_departure_is_reported(
    line: Line, session: Session
) -> None:
    """A two-camera check: A-cam was heard until 59 s before the departure and then never again
    (it died as the train came); it sent no departure photo. Judged only before the departure's
    receipt it is alive (59 s), though it was silent 5 min later while the train's rear may
    still have been passing it (departure-side evidence is adopted up to 10 min after).

    Found by the trial (fixed since): it was complete/free, A-cam not named (same window as above).
    """
    plan = Plan(line)
    plan.beat(set(ENDS) - {"A-cam"}, T0 - 10 * M, ARRIVE + 30 * S)
    plan.beat(["A-cam"], T0 - 11 * M + S, T0 - 59 * S)
    evidence(plan)
    run = plan.play()["depart"]["run"]
    assert_review_naming(line, run, "A-cam")
    replays_the_same(line, session)


def test_replay_after_a_late_departure_and_a_late_arrival(line: Line, session: Session) -> None:
    """Live and replay agree when both interlockings' reports came late and out of order."""
    arrive = T0 + 30 * M
    plan = Plan(line)
    plan.beat(set(ENDS) - {"A-ir"}, T0 - 10 * M, arrive + 12 * M)
    plan.beat(["A-ir"], T0 - 10 * M, T0 - 5 * M)
    plan.beat(["A-ir"], T0 + 10 * M, arrive + 12 * M)
    evidence(plan, arrive, skip=("A-ir",))
    plan.items = [i for i in plan.items if i[2] not in ("depart", "arrive")]
    plan.post(
        "B-ilk",
        "train_arrived",
        arrive,
        received=arrive + 5 * M,
        label="arrive",
        section="AB",
        train="2041",
    )
    plan.post(
        "A-ilk",
        "train_departed",
        T0,
        received=arrive + 11 * M,
        label="depart",
        section="AB",
        train="2041",
    )
    results = plan.play()
    assert results["arrive"]["unseen_run"], results["arrive"]
    assert results["depart"]["run"], results["depart"]
    replays_the_same(line, session)
