"""Derivations made to fail on purpose, for the tests of what a failed derivation leaves: a
section in review with a fault run a dispatcher decides (``service.clearance.faults``)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import pytest
from sqlalchemy import select
from sqlalchemy.orm import Session

from ingest import handlers as ingest_handlers
from ingest.handlers import Derivation
from service.clearance.models import Run

ERROR = "handler crashed on purpose"


@dataclass
class Breaker:
    """Makes the handlers of some kinds fail for the named event ids (after they wrote what
    they write, so the savepoint must undo it), and counts the failure handler's calls."""

    monkeypatch: pytest.MonkeyPatch
    ids: set[str] = field(default_factory=set)
    hooked: list[str] = field(default_factory=list)

    def kinds(self, *kinds: str) -> Breaker:
        for kind in kinds:
            real = ingest_handlers.HANDLERS[kind]
            self.monkeypatch.setitem(ingest_handlers.HANDLERS, kind, (self._wrap(real),))
        return self

    def _wrap(self, real: tuple[Any, ...]) -> Any:
        def handler(d: Derivation) -> dict[str, Any]:
            out: dict[str, Any] = {}
            for each in real:
                out.update(each(d) or {})
            if d.event.event_id in self.ids:
                raise RuntimeError(ERROR)
            return out

        return handler

    def count_hook(self) -> Breaker:
        """Count the calls of the installed failure handler (by event id)."""
        (real,) = ingest_handlers.FAILURE_HANDLERS

        def counted(d: Derivation, error: str) -> dict[str, Any] | None:
            self.hooked.append(d.event.event_id)
            return real(d, error)

        self.monkeypatch.setattr(ingest_handlers, "FAILURE_HANDLERS", [counted])
        return self


def fault_runs(session: Session) -> list[Run]:
    session.expire_all()
    return list(session.scalars(select(Run).where(Run.status == "fault").order_by(Run.id)))
