"""Two trains in one block section, posted as the devices would (HTTP) or as a broker batch
delivers them (several devices' events in one transaction, in the broker's order)."""

from __future__ import annotations

from datetime import datetime, timedelta
from typing import Any

from sqlalchemy.orm import Session

from core.models import Device
from ingest.multi_store import DeviceBatch, accept_batches
from tests.conftest import ADMIN
from tests.service.scenario import Line, iso


def run_of(line: Line, run: int) -> dict[str, Any]:
    answer = line.client.get(f"/api/v1/runs/{run}", headers=ADMIN)
    assert answer.status_code == 200, answer.text
    result: dict[str, Any] = answer.json()
    return result


def decide(
    line: Line, dispatcher: dict[str, str], run: int, action: str = "clear", status: int = 200
) -> dict[str, Any]:
    """A dispatcher's decision on a run; asserts the HTTP status it is answered with."""
    answer = line.client.post(
        f"/api/v1/runs/{run}/decision",
        json={"action": action, "reason": "looked at the images and the consists"},
        headers=dispatcher,
    )
    assert answer.status_code == status, answer.text
    result: dict[str, Any] = answer.json()
    return result


def depart(line: Line, at: datetime, train: str) -> dict[str, Any]:
    return line.post("A-ilk", "train_departed", at, section="AB", train=train)


def arrive(line: Line, at: datetime, train: str) -> dict[str, Any]:
    return line.post("B-ilk", "train_arrived", at, section="AB", train=train)


def resolve_all(line: Line, dispatcher: dict[str, str], runs: list[int]) -> None:
    """Clear the section's runs one by one, the way a dispatcher works the queue: the section
    is never free before the last one is cleared, and no action is a dead 409."""
    for index, run in enumerate(runs):
        state = decide(line, dispatcher, run)["state"]
        if index < len(runs) - 1:
            assert state != "free", (run, line.section())
    assert line.section()["state"] == "free", line.section()
    assert line.section()["conflict_runs"] == []


class Broker:
    """Events delivered as a broker batch: one transaction, in the order given."""

    def __init__(self, session: Session) -> None:
        self.session = session
        self.serial = 0

    def body(self, kind: str, at: datetime, **fields: Any) -> dict[str, Any]:
        self.serial += 1
        return {"event_id": f"mq-{self.serial}", "occurred_at": iso(at), "kind": kind, **fields}

    def deliver(self, *items: tuple[str, dict[str, Any]]) -> list[dict[str, Any]]:
        """``items``: (device id, event body), each device's batch in the order given."""
        batches = [
            DeviceBatch(self.session.get_one(Device, device), [body]) for device, body in items
        ]
        results = accept_batches(self.session, batches, transport="mqtt")
        self.session.commit()
        answers = [batch[0] for batch in results]
        for answer in answers:
            assert answer["status"] == "created", answer
        return [a["result"] for a in answers]


def transit(at: datetime, minutes: int) -> datetime:
    return at + timedelta(minutes=minutes)
