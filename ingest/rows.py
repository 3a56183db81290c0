"""Raw event rows at the statement level: one insert per event or per batch, answers in bulk.

Core statements on the ``raw_events`` table (no ORM unit of work): the unique key
``(device_id, event_id)`` decides duplicates inside the insert itself, so concurrent retries of
one event cannot both win, and a duplicate costs no failed statement.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable
from datetime import UTC, datetime
from typing import Any

from pydantic import ConfigDict, TypeAdapter
from sqlalchemy import Table, bindparam, select, text, update
from sqlalchemy.dialects import postgresql, sqlite
from sqlalchemy.exc import DataError, DBAPIError
from sqlalchemy.orm import Session

from core.database import utcnow
from core.models import Device
from ingest.models import RawEvent, StoredRaw
from ingest.schemas import FLAT_MODELS, section_of

RAW: Table = RawEvent.__table__  # type: ignore[assignment]
# One statement of constant text for any number of rows: the rows travel as one JSON document
# (one parameter), which PostgreSQL unpacks with ``json_to_recordset``. Arrays bound per column
# cost more: psycopg escapes each text element of a text-format array with a regular
# expression in Python, which was a third of a 500-event batch's time.
JSON_INSERT = text(
    "INSERT INTO raw_events (device_id, event_id, kind, occurred_at, received_at, section,"
    " transport, body, body_sha256, result)"
    " SELECT device_id, event_id, kind, occurred_at, received_at, section, transport, body,"
    " body_sha256, result FROM json_to_recordset(CAST(:rows AS json)) AS u(device_id text,"
    " event_id text, kind text, occurred_at timestamptz, received_at timestamptz,"
    " section text, transport text, body json, body_sha256 text, result json)"
    " ON CONFLICT (device_id, event_id) DO NOTHING RETURNING id, device_id, event_id"
)


# The rows' document, written by pydantic's serializer (times as ISO 8601 with their offset,
# microseconds kept): several times faster than ``json.dumps`` with a ``default`` for them.
# A NaN cannot be in an accepted event (every float field is checked finite); were one there,
# it is written as NaN, which PostgreSQL refuses, rather than silently stored as null.
_ROWS_JSON: TypeAdapter[list[dict[str, Any]]] = TypeAdapter(
    list[dict[str, Any]], config=ConfigDict(ser_json_inf_nan="constants")
)


def rows_document(rows: list[dict[str, Any]]) -> str:
    """The JSON document of raw event rows for :data:`JSON_INSERT`."""
    return _ROWS_JSON.dump_json(rows).decode()


# The canonical text that is hashed. One encoder for every call: ``json.dumps`` with options
# builds a new one each time, a third of the hash's cost. The text (and so every stored hash)
# is the same as ``json.dumps`` with these options writes.
_CANONICAL = json.JSONEncoder(
    sort_keys=True, separators=(",", ":"), ensure_ascii=False, default=str
)


# ``JSONEncoder.encode`` builds its C encoder anew on every call; made once here, with the
# same options (no check for circular data, which a parsed or validated event cannot hold),
# it writes the same text in two thirds of the time. None without the C accelerator.
_C_ENCODER: Callable[[Any, int], list[str]] | None = (
    None
    if getattr(json.encoder, "c_make_encoder", None) is None
    else json.encoder.c_make_encoder(  # type: ignore[attr-defined]
        None, str, json.encoder.encode_basestring, None, ":", ",", True, False, True
    )
)


def canonical_text(value: Any) -> str:
    """The canonical JSON text of ``value`` (sorted keys, no spaces, UTF-8, times by ``str``)."""
    if _C_ENCODER is None:
        return _CANONICAL.encode(value)
    return "".join(_C_ENCODER(value, 0))


def canonical_sha256(body: dict[str, Any]) -> str:
    return hashlib.sha256(canonical_text(body).encode()).hexdigest()


# Values that hold no time and nothing that could: left as they are without a call per value
# (which was most of the hash's cost for a batch of 500 events).
_PLAIN = frozenset({str, int, float, bool, type(None)})


def _instants(value: Any) -> Any:
    """``value`` with every time as a UTC instant, so that only what the event means is hashed."""
    if isinstance(value, datetime):
        return value.astimezone(UTC).isoformat()
    if isinstance(value, dict):
        return {
            key: item if item.__class__ in _PLAIN else _instants(item)
            for key, item in value.items()
        }
    if isinstance(value, list | tuple):
        if _PLAIN.issuperset(map(type, value)):
            return value  # a list of numbers or texts (JSON writes a tuple as a list too)
        return [_instants(item) for item in value]
    return value


def event_sha256(event: Any) -> str:
    """Idempotency hash of the validated event (protocol.md: "the same event" compares the
    validated event, not the text): ``Z`` and ``+00:00``, key order and number spelling give
    the same hash."""
    # The event models hold only texts, numbers, lists and maps of them and their times: what
    # ``model_dump`` returns is a copy of their field values, taken here without its cost.
    values = dict(event.__dict__) if type(event) in FLAT_MODELS else event.model_dump()
    for key, item in values.items():
        if item.__class__ not in _PLAIN:
            values[key] = _instants(item)
    return hashlib.sha256(canonical_text(values).encode()).hexdigest()


def raw_values(
    device: Device,
    event: Any,
    body: dict[str, Any],
    *,
    answer: dict[str, Any] | None,
    transport: str = "http",
    received: datetime | None = None,
) -> dict[str, Any]:
    """The row of one event; ``answer`` is stored with it when known before derivation.
    ``received``: when the server received it (default: now)."""
    values = {
        "device_id": device.id,
        "event_id": event.event_id,
        "kind": event.kind,
        "occurred_at": event.occurred_at,
        "received_at": received or utcnow(),
        "section": section_of(event),
        "body": body,
        "body_sha256": event_sha256(event),
        "result": answer or {},
        "transport": transport,
    }
    return values


def _insert(session: Session) -> Any:
    module = postgresql if session.get_bind().dialect.name == "postgresql" else sqlite
    return module.insert(RAW).on_conflict_do_nothing(index_elements=["device_id", "event_id"])


def insert_one(session: Session, values: dict[str, Any]) -> int | None:
    """Insert unless (device, event_id) exists: the new row's id, or None for a duplicate."""
    statement = _insert(session).values(**values).returning(RAW.c.id)
    return session.execute(statement).scalar_one_or_none()


def insert_many(session: Session, rows: list[dict[str, Any]]) -> dict[tuple[str, str], int]:
    """Insert the new rows in one statement; returns their ids by (device, ``event_id``).

    PostgreSQL gets ``INSERT … SELECT FROM json_to_recordset(document)``: one statement of
    constant text whatever the batch size, so neither SQLAlchemy nor the server compiles 500
    VALUES tuples, and one parameter to send.
    """
    if not rows:
        return {}
    if session.get_bind().dialect.name != "postgresql":
        statement = _insert(session).returning(RAW.c.id, RAW.c.device_id, RAW.c.event_id)
        return {(d, e): i for i, d, e in session.execute(statement, rows)}
    document = rows_document(rows)
    return {(d, e): i for i, d, e in session.execute(JSON_INSERT, {"rows": document})}


def insert_each_that_stores(
    session: Session, rows: list[dict[str, Any]], *, nothing_written: bool = False
) -> tuple[dict[tuple[str, str], int], dict[tuple[str, str], str]]:
    """:func:`insert_many`, except that a value the database refuses (``DataError``: a rule the
    validation does not know) refuses only the rows that hold it, never the whole batch: each
    item of a batch stands alone (protocol.md). Returns (ids of the inserted rows, the database's
    first line for each refused row), both by (device, ``event_id``).

    ``nothing_written``: the caller began the session's transaction itself and has only read
    in it, so a rollback loses nothing. The insert then goes without a savepoint (two round
    trips and a subtransaction less per batch); should the database refuse a value, the
    transaction is rolled back and the rows go in one savepoint each, as otherwise."""
    if nothing_written:
        try:
            return insert_many(session, rows), {}
        except DataError:
            session.rollback()  # only reads are lost; the checks they served stand
    else:
        try:
            with session.begin_nested():
                return insert_many(session, rows), {}
        except DataError:
            pass  # rare: find the rows that hold the value, one savepoint each
    inserted: dict[tuple[str, str], int] = {}
    refused: dict[tuple[str, str], str] = {}
    for row in rows:
        try:
            with session.begin_nested():
                inserted.update(insert_many(session, [row]))
        except DataError as exc:
            refused[(row["device_id"], row["event_id"])] = first_line(exc) or type(exc).__name__
    return inserted, refused


def first_line(exc: Exception) -> str:
    """An error's first line, for a database error the database's own (never the SQL statement
    and its parameters, which SQLAlchemy appends and which are the service's internals); empty
    for an error without words."""
    orig = exc.orig if isinstance(exc, DBAPIError) else None
    text = str(orig if orig is not None else exc).strip().splitlines()
    return text[0] if text else ""


def stored(session: Session, device_id: str, event_id: str) -> tuple[str, dict[str, Any]]:
    """(body hash, answer) of an event stored before."""
    row = session.execute(
        select(RAW.c.body_sha256, RAW.c.result).where(
            RAW.c.device_id == device_id, RAW.c.event_id == event_id
        )
    ).one()
    return row[0], row[1]


def stored_many(
    session: Session, keys: list[tuple[str, str]]
) -> dict[tuple[str, str], tuple[str, dict[str, Any]]]:
    """(body hash, answer) of events stored before, by (device, ``event_id``), in one query
    (a batch sent again after a lost answer must not cost a round trip per event)."""
    if not keys:
        return {}
    found: dict[tuple[str, str], tuple[str, dict[str, Any]]] = {}
    devices = sorted({device for device, _ in keys})
    for device in devices:
        ids = [event_id for d, event_id in keys if d == device]
        for start in range(0, len(ids), STORED_CHUNK):
            rows = session.execute(
                select(RAW.c.event_id, RAW.c.body_sha256, RAW.c.result).where(
                    RAW.c.device_id == device, RAW.c.event_id.in_(ids[start : start + STORED_CHUNK])
                )
            )
            found.update({(device, e): (h, r) for e, h, r in rows})
    return found


# Event ids per look-up of stored events (SQLite binds at most 32,766 parameters; a batch has
# at most 1000 events).
STORED_CHUNK = 1000


# The answers' update as the driver's own text: a group of 16 single events spent a fifth of
# its worker's CPU compiling and binding the ORM-level executemany, for 16 identical updates.
# psycopg still prepares it once and sends the parameter sets as one pipeline.
_ANSWER_UPDATE = "UPDATE raw_events SET result = %s::json, derive_error = %s WHERE id = %s"
_ANSWER_JSON: TypeAdapter[dict[str, Any]] = TypeAdapter(dict[str, Any])


def write_answers(session: Session, answers: list[dict[str, Any]]) -> None:
    """Store derived answers (``id``, ``result``, ``derive_error``) with one executemany,
    which psycopg sends as one pipeline; cleared afterwards. (One ``UPDATE … FROM
    json_to_recordset`` instead cost PostgreSQL more CPU than the prepared updates, measured
    for groups of 16 axle counts; the Python side was the same.)"""
    if not answers:
        return
    if session.get_bind().dialect.name == "postgresql":
        session.flush()  # what the derivations added goes first, as an ORM statement would
        parameters = [
            (_ANSWER_JSON.dump_json(a["result"]).decode(), a["derive_error"], a["id"])
            for a in answers
        ]
        session.connection().exec_driver_sql(_ANSWER_UPDATE, parameters)
        answers.clear()
        return
    statement = (
        update(RAW)
        .where(RAW.c.id == bindparam("raw_id"))
        .values(
            result=bindparam("answer", type_=RAW.c.result.type),
            derive_error=bindparam("error", type_=RAW.c.derive_error.type),
        )
    )
    session.execute(
        statement,
        [{"raw_id": a["id"], "answer": a["result"], "error": a["derive_error"]} for a in answers],
    )
    answers.clear()


def as_raw(raw_id: int, values: dict[str, Any]) -> StoredRaw:
    """The stored row, for derivations (which only read it)."""
    return StoredRaw(
        id=raw_id,
        device_id=values["device_id"],
        event_id=values["event_id"],
        kind=values["kind"],
        occurred_at=values["occurred_at"],
        received_at=values["received_at"],
        section=values["section"],
        body=values["body"],
        body_sha256=values["body_sha256"],
        result=values["result"],
    )
