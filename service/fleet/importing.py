"""Import of bench measurements from CSV: all rows or none, with errors that name the fix.

Two layouts are accepted: *wide*, ``car,taken_at,<parameter>,<parameter>,…`` (one test per
row, an empty cell is a parameter not measured), and *long*, ``car,taken_at,parameter,value``.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Iterable
from datetime import datetime
from typing import TextIO

from sqlalchemy import insert, select
from sqlalchemy.orm import Session

from core.errors import Unprocessable
from core.models import Car
from ingest.schemas import EARLIEST, LATEST
from service.fleet.models import Measurement
from service.fleet.service import measurement_row

KEYS = ("car", "taken_at")
LONG = ("parameter", "value")
EXAMPLE = "car,taken_at,brake_cylinder_fill_s,door_close_s"
_SHOWN = 5  # errors listed before "… and N more"
_INSERT_CHUNK = 1000

Test = tuple[str, datetime, dict[str, float]]


def _when(text: str, line: int, errors: list[str]) -> datetime | None:
    try:
        at = datetime.fromisoformat(text.strip())
    except ValueError:
        errors.append(f"line {line}: taken_at {text!r} is not an ISO 8601 time")
        return None
    if at.tzinfo is None:
        errors.append(f"line {line}: taken_at {text!r} has no offset; write e.g. {text}Z")
        return None
    if not EARLIEST <= at < LATEST:
        errors.append(f"line {line}: taken_at {text!r} is not between 2000 and 2100")
        return None
    return at


def _number(text: str, line: int, column: str, errors: list[str]) -> float | None:
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not math.isfinite(value):
        errors.append(f"line {line}, column {column}: {text!r} is not a finite number")
        return None
    return value


def parse_tests(stream: TextIO) -> list[Test]:
    """The tests in a CSV file; raises Unprocessable listing the bad lines."""
    reader = csv.DictReader(stream)
    header = [name.strip() for name in (reader.fieldnames or [])]
    missing = [key for key in KEYS if key not in header]
    if missing:
        raise Unprocessable(
            f"the CSV lacks the column(s) {', '.join(missing)}; the first line must be a header"
            f" like {EXAMPLE} (or car,taken_at,parameter,value)"
        )
    reader.fieldnames = header
    long = set(LONG) <= set(header)
    params = [name for name in header if name not in KEYS and name]
    errors: list[str] = []
    tests: dict[tuple[str, datetime], dict[str, float]] = {}
    for line, row in enumerate(reader, start=2):
        car, at = (row.get("car") or "").strip(), _when(row.get("taken_at") or "", line, errors)
        if not car:
            errors.append(f"line {line}: the car is empty")
        if long:
            name = (row.get("parameter") or "").strip()
            if not name:
                errors.append(f"line {line}: the parameter is empty")
            cells = {name: row.get("value")} if name else {}
        else:
            cells = {p: row.get(p) for p in params}
        values = {}
        for name, text in cells.items():
            if text is None or not text.strip():
                continue
            value = _number(text, line, name if not long else "value", errors)
            if value is not None:
                values[name] = value
        if car and at is not None and values:
            tests.setdefault((car, at), {}).update(values)
    _raise(errors, "fix these lines and import the file again (nothing was imported)")
    if not tests:
        raise Unprocessable("the CSV holds no measurements; add rows under the header")
    return [(car, at, values) for (car, at), values in tests.items()]


def _raise(errors: list[str], fix: str) -> None:
    if errors:
        more = f"; … and {len(errors) - _SHOWN} more" if len(errors) > _SHOWN else ""
        raise Unprocessable(f"{'; '.join(errors[:_SHOWN])}{more} — {fix}")


def import_tests(session: Session, tests: Iterable[Test]) -> tuple[int, int]:
    """Store parsed tests (source ``csv``), one row each; returns (tests, values)."""
    tests = list(tests)
    cars = {car for car, _, _ in tests}
    known = set(session.scalars(select(Car.id).where(Car.id.in_(cars))))
    unknown = sorted(cars - known)
    if unknown:
        listed = ", ".join(unknown[:10]) + (" …" if len(unknown) > 10 else "")
        raise Unprocessable(
            f"unknown car(s) {listed}; register them (POST /api/v1/cars) or correct the car"
            " column, then import again (nothing was imported)"
        )
    layouts: dict[str, int] = {}
    rows = [measurement_row(session, c, at, v, source="csv", known=layouts) for c, at, v in tests]
    for start in range(0, len(rows), _INSERT_CHUNK):
        session.connection().execute(insert(Measurement), rows[start : start + _INSERT_CHUNK])
    session.flush()
    return len(tests), sum(len(v) for _, _, v in tests)
