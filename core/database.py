"""Engine, sessions and the request-scoped transaction owner."""

from __future__ import annotations

from collections.abc import AsyncIterator
from datetime import UTC, datetime
from functools import lru_cache
from typing import Annotated, Any

import anyio
from fastapi import Depends
from fastapi.concurrency import run_in_threadpool
from sqlalchemy import DateTime, Engine, MetaData, create_engine, event
from sqlalchemy.orm import DeclarativeBase, Session, sessionmaker
from sqlalchemy.types import TypeDecorator

from core.settings import get_settings

NAMING_CONVENTION = {
    "ix": "ix_%(column_0_label)s",
    "uq": "uq_%(table_name)s_%(column_0_N_name)s",
    "ck": "ck_%(table_name)s_%(constraint_name)s",
    "fk": "fk_%(table_name)s_%(column_0_name)s_%(referred_table_name)s",
    "pk": "pk_%(table_name)s",
}


class Base(DeclarativeBase):
    metadata = MetaData(naming_convention=NAMING_CONVENTION)


class UTCDateTime(TypeDecorator[datetime]):
    """Timezone-aware UTC datetimes on every backend (SQLite stores naive values)."""

    impl = DateTime(timezone=True)
    cache_ok = True

    def process_bind_param(self, value: datetime | None, dialect: Any) -> datetime | None:
        if value is None:
            return None
        if value.tzinfo is None:
            raise ValueError("naive datetime given; times must carry an offset")
        return value.astimezone(UTC)

    def process_result_value(self, value: datetime | None, dialect: Any) -> datetime | None:
        if value is None:
            return None
        return value.replace(tzinfo=UTC) if value.tzinfo is None else value.astimezone(UTC)


def utcnow() -> datetime:
    return datetime.now(UTC)


def make_engine(url: str) -> Engine:
    if url.startswith("sqlite"):
        engine = create_engine(url, connect_args={"check_same_thread": False, "timeout": 30})

        @event.listens_for(engine, "connect")
        def _sqlite_pragmas(dbapi_connection: Any, _: Any) -> None:
            cursor = dbapi_connection.cursor()
            # WAL lets readers proceed while one writer commits; foreign keys are off by default.
            cursor.execute("PRAGMA journal_mode=WAL")
            cursor.execute("PRAGMA synchronous=NORMAL")
            cursor.execute("PRAGMA foreign_keys=ON")
            cursor.execute("PRAGMA busy_timeout=30000")
            cursor.close()
            # Let SQLAlchemy, not the driver, begin transactions (see _sqlite_begin).
            dbapi_connection.isolation_level = None

        @event.listens_for(engine, "begin")
        def _sqlite_begin(connection: Any) -> None:
            # Take the write lock up front: a deferred transaction that reads and then writes can
            # fail at once with "database is locked" when another writer got there first.
            connection.exec_driver_sql("BEGIN IMMEDIATE")

        return engine
    engine = create_engine(url, pool_pre_ping=True, pool_size=10, max_overflow=20)
    if engine.dialect.name == "postgresql":
        # Rows the ORM inserts together (a group's axle readings) go in as one multi-row INSERT
        # rather than an executemany, which PostgreSQL runs as one statement per row. Inserts
        # with ON CONFLICT keep the executemany (SQLAlchemy decides that itself).
        engine.dialect.use_insertmanyvalues_wo_returning = True
    return engine


@lru_cache
def get_engine() -> Engine:
    return make_engine(get_settings().resolved_database_url)


@lru_cache
def get_sessionmaker() -> sessionmaker[Session]:
    return sessionmaker(bind=get_engine(), expire_on_commit=False)


async def get_session() -> AsyncIterator[Session]:
    """The one owner of a request's transaction: commit on success, roll back on error.

    Used with ``scope="function"`` so that the commit happens before the response is sent:
    a client is never told "created" about something that was not committed.

    An async dependency, so that a session that never began a transaction (an event the
    group commit stores in its own session, a device key found in the cache) is made and
    closed on the event loop, with no I/O. As a sync generator every request paid two hops
    to a worker thread and back, an eighth of a worker's CPU for single events. Only a
    session holding a transaction commits, rolls back or closes in a thread (it talks to
    the database); that clean-up is shielded, so a cancelled request still ends its
    transaction.
    """
    session = get_sessionmaker()()
    try:
        yield session
        if session.in_transaction():
            await run_in_threadpool(session.commit)
    except BaseException:
        with anyio.CancelScope(shield=True):
            await _in_thread_if_begun(session, session.rollback)
        raise
    finally:
        with anyio.CancelScope(shield=True):
            await _in_thread_if_begun(session, session.close)


async def _in_thread_if_begun(session: Session, end: Any) -> None:
    """``end()``: in a worker thread when ``session`` holds a transaction, else here."""
    if session.in_transaction():
        await run_in_threadpool(end)
    else:
        end()


DbSession = Annotated[Session, Depends(get_session, scope="function")]
