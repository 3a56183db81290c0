"""Import of bench measurements from CSV: all rows or none, with errors that name the fix.

Two layouts are accepted: *wide*, ``car,taken_at,<parameter>,<parameter>,…`` (one test per
row, an empty cell is a parameter not measured), and *long*, ``car,taken_at,parameter,value``.
Every parameter must be registered and every value plausible (`service.fleet.rules`, the same
rule as the API and ``measurement`` events); a row with more or fewer fields than the header
(a decimal comma, a lost separator) is refused. Importing the same file again stores nothing
twice: a test already stored with the same values is skipped.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Iterable, Mapping
from datetime import datetime
from typing import Any, TextIO

from sqlalchemy import insert, select
from sqlalchemy.orm import Session

from core.errors import Unprocessable
from core.models import Car
from ingest.schemas import EARLIEST, LATEST
from service.fleet.models import Measurement, Parameter
from service.fleet.rules import value_problems
from service.fleet.service import measured_values, measurement_row

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


def _shape_problem(row: dict[Any, Any], line: int, width: int) -> str | None:
    extra = row.get(None)  # DictReader puts fields beyond the header under the key None
    if extra:
        return (
            f"line {line}: {width + len(extra)} fields for {width} columns — a decimal comma?"
            " write 3.1 with a point, or quote the field"
        )
    if any(value is None for key, value in row.items() if key is not None):
        return f"line {line}: fewer fields than the {width} columns of the header"
    return None


def _unknown_columns(params: list[str], parameters: Mapping[str, Parameter]) -> list[str]:
    unknown = {name: 0.0 for name in params if name not in parameters}
    return [f"column {name}: {why}" for name, why in value_problems(parameters, unknown).items()]


def parse_tests(stream: TextIO, parameters: Mapping[str, Parameter]) -> list[Test]:
    """The tests in a CSV file, checked against the registered ``parameters``; raises
    Unprocessable listing the bad lines and columns (nothing is imported then)."""
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
    errors = [] if long else _unknown_columns(params, parameters)
    tests: dict[tuple[str, datetime], dict[str, float]] = {}
    for line, row in enumerate(reader, start=2):
        shape = _shape_problem(row, line, len(header))
        if shape:
            errors.append(shape)
            continue
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
        refused = value_problems(parameters, values)
        if not long:  # unknown columns were reported once, from the header
            refused = {k: v for k, v in refused.items() if k in parameters}
        errors.extend(f"line {line}, column {name}: {why}" for name, why in refused.items())
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


def _already_stored(session: Session, tests: list[Test]) -> tuple[list[Test], list[str]]:
    """The tests not stored yet, and the conflicts: a stored test with other values."""
    cars = {car for car, _, _ in tests}
    stored: dict[tuple[str, datetime], dict[str, float]] = {}
    for row in session.scalars(select(Measurement).where(Measurement.car_id.in_(cars))):
        stored[(row.car_id, row.taken_at)] = measured_values(session, row)
    new, conflicts = [], []
    for car, at, values in tests:
        before = stored.get((car, at))
        if before is None:
            new.append((car, at, values))
        elif before != values:
            conflicts.append(f"car {car} at {at.isoformat()} is stored with other values")
    return new, conflicts


def import_tests(session: Session, tests: Iterable[Test]) -> tuple[int, int]:
    """Store parsed tests (source ``csv``), one row each; returns (tests, values) stored.

    Tests already stored with the same values are skipped (a re-import stores nothing).
    """
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
    tests, conflicts = _already_stored(session, tests)
    _raise(conflicts, "correct the file or the stored tests (nothing was imported)")
    layouts: dict[str, int] = {}
    rows = [measurement_row(session, c, at, v, source="csv", known=layouts) for c, at, v in tests]
    for start in range(0, len(rows), _INSERT_CHUNK):
        session.connection().execute(insert(Measurement), rows[start : start + _INSERT_CHUNK])
    session.flush()
    return len(tests), sum(len(v) for _, _, v in tests)
