"""What the review screen shows: sections, the queue, stale devices, one run in detail, the
actions that still make sense on it, and the alerts the page sounds."""

from __future__ import annotations

from dataclasses import dataclass
from datetime import datetime
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session

from core.models import Section
from core.timefmt import elapsed
from ingest import liveness
from service.clearance import occupancy, overdue
from service.clearance.models import Run
from service.clearance.rules import SWEEP_FROM
from service.clearance.service import ACTION_STATES
from service.clearance.views import QUEUE_STATES, run_out, section_out

STATE_WORDS = {
    "free": "free",
    "occupied": "occupied",
    "awaiting_confirmation": "awaiting confirmation",
    "review": "needs review",
    "alarm": "ALARM",
    "blocked": "blocked",
    "awaiting_sweep": "awaiting sweep",
}
# "in alarm for 12 min": how each queue state reads with its duration.
SINCE_WORDS = {
    "alarm": "in alarm",
    "review": "needs review",
    "awaiting_confirmation": "awaiting confirmation",
    "blocked": "blocked",
}
DONE_WORDS = {"clear": "cleared", "keep_blocked": "kept blocked", "sweep": "held for a sweep train"}
ACTION_LABELS = {
    "clear": "Clear the section",
    "keep_blocked": "Keep blocked",
    "sweep": "Clear after a sweep train",
}
ALERT_STATES = ("alarm", "review")
# The queue's order: most urgent first (then oldest first within a state).
QUEUE_SEVERITY = (
    "alarm",
    "review",
    "awaiting_confirmation",
    "blocked",
)  # states that sound and notify when they appear
CONSIST_WORDS = {
    "identical": "same cars, same order",
    "missing": "cars missing",
    "unknown": "cannot tell (cars not all identified)",
}
DECIDERS = ("dispatcher", "admin")
# Devices that report now and then by nature (marking, bench, on-board): never listed as stale
# (nor counted by ``/metrics``, which counts this list).
OCCASIONAL_KINDS = ("marking_station", "test_bench", "onboard_unit")
# Clearing from these states overrides evidence of a loss: the page asks once more.
CONFIRM_CLEAR = {"alarm": "in ALARM", "awaiting_sweep": "waiting for its sweep train"}


@dataclass(frozen=True)
class Screen:
    sections: list[dict[str, Any]]
    queue: list[dict[str, Any]]
    stale: list[dict[str, Any]]
    recent: list[dict[str, Any]]
    run: dict[str, Any] | None
    actions: list[str]
    confirm: dict[str, str]  # action → the question asked before it is sent
    decided: dict[str, Any] | None
    alerts: list[dict[str, Any]]
    title: str


def stale_devices(session: Session, now: datetime) -> list[dict[str, Any]]:
    """The devices serving a section that are stale by the one liveness rule
    (:func:`ingest.liveness.stale_devices`: server receive times, decommissioned never)."""
    return [
        {
            "id": device.id,
            "kind": device.kind,
            "station": device.station,
            "last_seen_at": device.last_seen_at,
        }
        for device in liveness.stale_devices(session, now)
        if device.kind not in OCCASIONAL_KINDS
    ]


def sensible_actions(
    section: dict[str, Any] | None, run: dict[str, Any] | None, *, overtaken: bool = False
) -> list[str]:
    """The actions that would change something, safest first on an alarm.

    Only on the section's current run, arrived (or ``overtaken``: its arrival never came but
    the train behind it arrived, or its section has been silent long enough: ``overdue``,
    where a still ``occupied`` section is first kept blocked or swept, never cleared); never
    the action whose state the section is already in;
    nothing on a free section; a sweep only where nothing proves the section empty.
    """
    if section is None or run is None or (run["status"] != "arrived" and not overtaken):
        return []
    if section["last_run_id"] != run["id"] or section["state"] == "free":
        return []
    if section["state"] == "occupied":
        # a train that never arrived in a silent section (``overdue``): block or sweep first
        return ["keep_blocked", "sweep"] if overtaken else []
    order = ["keep_blocked", "clear"] if section["state"] == "alarm" else ["clear", "keep_blocked"]
    order.append("sweep")
    state = section["state"]
    return [a for a in order if ACTION_STATES[a] != state and (a != "sweep" or state in SWEEP_FROM)]


def last_decision(run: dict[str, Any] | None) -> dict[str, Any] | None:
    """Which action was taken on the run, by whom and when (the latest audit record)."""
    if not run or not run["overrides"]:
        return None
    record = run["overrides"][-1]
    return {**record, "words": DONE_WORDS.get(record["action"], record["action"])}


def _since(section: dict[str, Any], now: datetime) -> str:
    state: str = section["state"]
    words = SINCE_WORDS.get(state, state)
    since = section["state_since"]
    if not since:
        return words
    return f"{words} for {elapsed(since, now)}"


def queue_order(queue: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The queue as a dispatcher works it: alarms first, then runs that need review, then the
    rest (awaiting confirmation, blocked), each oldest first — a new alarm is never below an
    older review."""
    rank = {state: i for i, state in enumerate(QUEUE_SEVERITY)}
    return sorted(queue, key=lambda s: (rank.get(s["state"], len(rank)), s["state_since"] or ""))


SETTLED_WORDS = {"blocked": "kept blocked by a dispatcher", "alarm": "in alarm"}


def _conflict_words(session: Session, section: dict[str, Any]) -> str | None:
    """Two trains in one section, in words: the alarm itself, before any reason of the run
    (a missing photo of the train ahead is secondary to a second train behind it)."""
    run = section["run"]
    if run and run["conflict"]:
        return str(run["conflict"])
    if not section["conflict_runs"]:
        return None
    waiting = session.get(Run, section["conflict_runs"][0])
    if waiting is not None and waiting.conflict:
        return waiting.conflict
    return (
        f"run {section['conflict_runs'][0]} departed into section {section['id']} before it"
        " was cleared: two trains in one section"
    )


def headline(session: Session, section: dict[str, Any]) -> str:
    """The one line a dispatcher reads first for a queued section: why it needs a person.

    Two trains in one section first: the alarm that matters most. Else the current run's first
    reason when its verdict is not ``complete`` (reasons are ordered blocking first). A
    complete run in a section that is not free is not the reason: the
    section is held by something else — a train waiting behind it, an earlier run's late proof
    of loss, a dispatcher's block — and that is named instead of "tail disc present".
    """
    run = section["run"]
    decision = run["decision"] if run else None
    reasons = decision["reasons"] if decision else []
    loss = _earlier_loss(session, section) if section["state"] == "alarm" else None
    if loss and run and run["status"] == occupancy.FAULT:
        return loss  # a proof of loss outranks an event that could not be processed
    conflict = _conflict_words(session, section)
    if conflict:
        return conflict
    if section.get("overdue"):
        return str(section["overdue"])
    if decision and decision["verdict"] != "complete" and reasons:
        return str(reasons[0])
    waiting = section["fault_runs"] and session.get(Run, section["fault_runs"][0])
    if waiting and waiting.conflict:  # after this run's own reasons: it is decided first
        return f"run {waiting.id} waits behind this run: {waiting.conflict}"
    if loss:
        return loss
    if section["state"] in SETTLED_WORDS and decision and decision["verdict"] == "complete":
        return f"section {SETTLED_WORDS[section['state']]}; this run arrived complete"
    return str(reasons[0]) if reasons else ""


def _earlier_loss(session: Session, section: dict[str, Any]) -> str | None:
    """An earlier run's proof of loss that holds a section in alarm (its latest), in words."""
    earlier = session.scalars(
        select(Run)
        .where(Run.section == section["id"], Run.id != section["run"]["id"])
        .where(Run.verdict == "incomplete")
        .order_by(Run.id.desc())
        .limit(1)
    ).first()
    if earlier is None or not earlier.reasons:
        return None
    return f"run {earlier.id} (train {earlier.train}): {earlier.reasons[0]}"


def _overdue(session: Session, section: dict[str, Any], now: datetime) -> str | None:
    """Why a section's train that never arrived is for a person now (``overdue``), or None."""
    run = section["run"]
    if run is None or run["arrived_at"] is not None or section["state"] == "free":
        return None
    found = session.get(Run, run["id"])
    return None if found is None else overdue.overdue(session, found, now)


def _may_act_unarrived(session: Session, run: Run, now: datetime) -> bool:
    return occupancy.overtaken(session, run) or overdue.overdue(session, run, now) is not None


def _title(queue: list[dict[str, Any]]) -> str:
    alarms = [s["id"] for s in queue if s["state"] == "alarm"]
    if alarms:
        return f"ALARM {', '.join(alarms)} · depot — review ({len(queue)})"
    return f"depot — review ({len(queue)})" if queue else "depot — review"


def build_screen(
    session: Session, *, run_id: int | None, now: datetime, role: str = "dispatcher"
) -> Screen:
    sections = [
        section_out(session, s) for s in session.scalars(select(Section).order_by(Section.id))
    ]
    for s in sections:
        s["overdue"] = _overdue(session, s, now)
    queue = queue_order(
        [
            s
            for s in sections
            if (s["state"] in QUEUE_STATES or s["overdue"]) and s["run"] is not None
        ]
    )
    for s in queue:
        s["since_words"] = _since(s, now)
        s["headline"] = headline(session, s)
    recent_runs = session.scalars(select(Run).order_by(Run.id.desc()).limit(15)).all()
    recent = [run_out(session, r) for r in recent_runs]
    if run_id is None and queue:
        run_id = queue[0]["run"]["id"]
    found = session.get(Run, run_id) if run_id is not None else None
    run = run_out(session, found) if found else None
    held = next((s for s in sections if run and s["id"] == run["section"]), None)
    released = found is not None and found.arrived_at is None
    released = released and found is not None and _may_act_unarrived(session, found, now)
    released = released or (found is not None and occupancy.is_fault(found))  # no train
    actions = sensible_actions(held, run, overtaken=released) if role in DECIDERS else []
    confirm = {}
    if held and held["state"] in CONFIRM_CLEAR:
        confirm["clear"] = (
            f"Clear section {held['id']} although it is {CONFIRM_CLEAR[held['state']]}?"
            " Only when you know the section is empty."
        )
    alerts = [
        {
            "section": s["id"],
            "state": s["state"],
            "run": s["run"]["id"],
            "train": s["run"]["train"],
            "since": s["state_since"],
        }
        for s in queue
        if s["state"] in ALERT_STATES
    ]
    return Screen(
        sections,
        queue,
        stale_devices(session, now),
        recent,
        run,
        actions,
        confirm,
        last_decision(run),
        alerts,
        _title(queue),
    )


# A read number no registered car has is shown as "#250" (``clearance.evidence``); a car id
# never starts with "#" (``setup.names.NAME_PATTERN``).
UNREGISTERED = "#"


def _unregistered(label: str | None) -> bool:
    return label is not None and label.startswith(UNREGISTERED)


def aligned_rows(run: dict[str, Any]) -> list[dict[str, Any]]:
    """Consists car by car for display, one table per reader technology, with the numbers
    read that are not in the fleet register (an independent trial: #250 on both sides passed
    ``complete`` with nothing said; the verdict stands, the screen names the car)."""
    tables = []
    for family, comparison in sorted(run["evidence"].get("consist_comparison", {}).items()):
        rows = [
            {
                "departure": r[0],
                "arrival": r[1],
                "mark": r[2],
                "unregistered": _unregistered(r[0]) or _unregistered(r[1]),
            }
            for r in comparison["aligned"]
        ]
        strangers = {c for r in comparison["aligned"] for c in r[:2] if _unregistered(c)}
        tables.append(
            {
                "family": {"wheel": "wheel marks", "ir": "infrared"}.get(family, family),
                "status": comparison["status"],
                "status_words": CONSIST_WORDS.get(comparison["status"], comparison["status"]),
                "rows": rows,
                "unregistered": sorted(strangers),
            }
        )
    return tables
