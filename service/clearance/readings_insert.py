"""A transaction's new axle readings go in with one statement of constant text (PostgreSQL).

A group commit of single axle counts adds one ``AxleReading`` per count. The ORM writes them as
one multi-row ``INSERT … VALUES``, whose text grows with the group: psycopg then converts the
placeholders of every new text again (its cache holds statements of at most 50 parameters),
which with the ORM's unit of work was a quarter of such a group's CPU. Here, before each flush,
the session's new readings are written as ``INSERT … SELECT FROM json_to_recordset(document)``
(one parameter, the same text for any number of rows, as ``ingest.rows`` writes raw events)
and leave the unit of work. Later reads in the transaction load them from the table, as they
would the ORM's rows. SQLite keeps the ORM's insert.
"""

from __future__ import annotations

from functools import cache
from typing import Any

from sqlalchemy import Table, TextClause, event, text
from sqlalchemy.dialects import postgresql
from sqlalchemy.orm import Session

from ingest.rows import rows_document
from service.clearance.models import AxleReading

TABLE: Table = AxleReading.__table__  # type: ignore[assignment]
# Every column is given by the deriving code: a column with a default the ORM would fill in
# must not be left to NULL here.
assert not any(c.default is not None or c.server_default is not None for c in TABLE.columns)
COLUMNS = [column.name for column in TABLE.columns]


@cache
def insert_statement() -> TextClause:
    """The statement (built at first use: a foreign key's column type is known only once the
    table it refers to is mapped)."""
    dialect = postgresql.dialect()  # type: ignore[no-untyped-call]
    types = ", ".join(f"{c.name} {c.type.compile(dialect=dialect)}" for c in TABLE.columns)
    return text(
        f"INSERT INTO {TABLE.name} ({', '.join(COLUMNS)}) SELECT {', '.join(COLUMNS)}"
        f" FROM json_to_recordset(CAST(:rows AS json)) AS u({types})"
    )


@event.listens_for(Session, "before_flush")
def _readings_first(session: Session, *_: Any) -> None:
    readings = [row for row in session.new if type(row) is AxleReading]
    if not readings or session.get_bind().dialect.name != "postgresql":
        return
    rows = [{name: getattr(row, name) for name in COLUMNS} for row in readings]
    session.connection().execute(insert_statement(), {"rows": rows_document(rows)})
    for row in readings:
        session.expunge(row)
