"""Group commit: concurrent single events of one worker share one transaction and WAL flush.

The first event to arrive waits ``DEPOT_GROUP_COMMIT_MS`` for neighbours (or until
``DEPOT_GROUP_COMMIT_MAX`` have come); the group is then stored in one transaction in a worker
thread while the next group gathers. Each request is answered only after its group's commit:
nothing is acknowledged before it is durable, and a crash loses only unanswered events, which
the devices retry. When anything in a group fails at the database, the whole transaction is
rolled back and every event of the group is stored again in a transaction of its own, so one
event's failure never fails its neighbours. PostgreSQL only: on SQLite (one writer at a time)
and with ``DEPOT_GROUP_COMMIT_MS=0`` every event commits by itself.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from fastapi.concurrency import run_in_threadpool
from sqlalchemy import Engine
from sqlalchemy.orm import Session, sessionmaker

from core.models import Device

log = logging.getLogger("depot.ingest")
Outcome = tuple[int, dict[str, Any]] | BaseException
# Stores a group in one session; returns one outcome per event, in order (see service).
GroupStore = Callable[[Session, list[tuple[Device, Any, dict[str, Any]]]], list[Outcome]]
SingleStore = Callable[[Session, Device, Any, dict[str, Any]], tuple[int, dict[str, Any]]]


@dataclass
class _Pending:
    device: Device
    event: Any
    body: dict[str, Any]
    future: asyncio.Future[tuple[int, dict[str, Any]]] = field(repr=False)


class GroupCommitter:
    """One per worker process, event loop and database."""

    def __init__(
        self,
        factory: sessionmaker[Session],
        store_group: GroupStore,
        store_one: SingleStore,
        *,
        window_s: float,
        max_events: int,
    ) -> None:
        self.factory, self.store_group, self.store_one = factory, store_group, store_one
        self.window_s, self.max_events = window_s, max_events
        self._pending: list[_Pending] = []
        self._full = asyncio.Event()
        self._runner: asyncio.Task[None] | None = None

    async def submit(self, device: Device, event: Any, body: dict[str, Any]) -> Any:
        """Store one validated event with its neighbours; (status, result) after the commit."""
        future: asyncio.Future[tuple[int, dict[str, Any]]] = (
            asyncio.get_running_loop().create_future()
        )
        self._pending.append(_Pending(device, event, body, future))
        if len(self._pending) >= self.max_events:
            self._full.set()
        if self._runner is None or self._runner.done():
            self._runner = asyncio.create_task(self._run())
        return await future

    async def _run(self) -> None:
        # Only the first group waits for the window: later ones gathered while the previous
        # group was committing, which under load is the natural size of a group.
        with contextlib.suppress(TimeoutError):
            await asyncio.wait_for(self._full.wait(), self.window_s)
        while self._pending:
            group = self._pending[: self.max_events]
            del self._pending[: self.max_events]
            if len(self._pending) < self.max_events:
                self._full.clear()
            outcomes: list[Outcome]
            try:
                outcomes = await run_in_threadpool(self._commit, group)
            except Exception as exc:  # every waiter must hear of it
                outcomes = [exc] * len(group)
            for pending, outcome in zip(group, outcomes, strict=True):
                if pending.future.done():
                    continue  # the client went away; its event is stored all the same
                if isinstance(outcome, BaseException):
                    pending.future.set_exception(outcome)
                else:
                    pending.future.set_result(outcome)

    def _commit(self, group: list[_Pending]) -> list[Outcome]:
        items = [(p.device, p.event, p.body) for p in group]
        session = self.factory()
        try:
            outcomes = self.store_group(session, items)
            session.commit()
            return outcomes
        except Exception as exc:
            session.rollback()
            # Also a group of one: the group derives without a savepoint, and only the event's
            # own transaction keeps a raw event whose derivation fails (201, derive_error).
            log.warning("group of %d events failed (%s); storing them one by one", len(group), exc)
        finally:
            session.close()
        return [self._alone(*item) for item in items]

    def _alone(self, device: Device, event: Any, body: dict[str, Any]) -> Outcome:
        session = self.factory()
        try:
            outcome = self.store_one(session, device, event, body)
            session.commit()
            return outcome
        except Exception as exc:
            session.rollback()
            return exc
        finally:
            session.close()


_committers: dict[tuple[int, int], GroupCommitter] = {}


def committer_for(
    session: Session,
    store_group: GroupStore,
    store_one: SingleStore,
    *,
    window_ms: float,
    max_events: int,
) -> GroupCommitter | None:
    """The committer for the request session's database, or None when group commit is off
    (setting 0, SQLite, or a session bound to a connection, as in tests that roll back)."""
    bind = session.get_bind()
    if window_ms <= 0 or not isinstance(bind, Engine) or bind.dialect.name != "postgresql":
        return None
    loop = asyncio.get_running_loop()
    key = (id(bind), id(loop))
    committer = _committers.get(key)
    if committer is None:
        for stale in [k for k in _committers if k[1] != id(loop)]:
            del _committers[stale]  # a finished event loop (tests); its tasks are gone
        factory = sessionmaker(bind=bind, expire_on_commit=False)
        committer = _committers[key] = GroupCommitter(
            factory, store_group, store_one, window_s=window_ms / 1000, max_events=max_events
        )
    return committer
