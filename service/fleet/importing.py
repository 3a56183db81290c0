"""Import of bench measurements from CSV: all rows or none, with errors that name the fix.

Two layouts are accepted: *wide*, ``car,taken_at,<parameter>,<parameter>,…`` (one test per
row, an empty cell is a parameter not measured), and *long*, ``car,taken_at,parameter,value``.
Every parameter must be registered and every value plausible (`service.fleet.rules`, the same
rule as the API and ``measurement`` events); a value is written in ASCII decimal digits (``3.1``,
``-0.25``, ``2.4e-3``: never ``3.1_0`` or ``٣.١``, which Python's ``float`` would read); no test
is dated further ahead than the events' allowed clock skew (``DEPOT_MAX_CLOCK_SKEW_S``); a row
with more or fewer fields than the header (a decimal comma, a lost separator) is refused.
Importing the same file again stores nothing twice: a test already stored with the same values
is skipped.
"""

from __future__ import annotations

import csv
import math
import re
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from datetime import datetime
from typing import TextIO

from sqlalchemy import select
from sqlalchemy.orm import Session

from core.database import utcnow
from core.errors import Unprocessable
from core.models import Car
from ingest.schemas import EARLIEST, LATEST
from service.fleet.csv_checks import decimal_comma_problems
from service.fleet.models import Measurement, Parameter
from service.fleet.rules import ahead_problem, value_problems
from service.fleet.service import insert_ignoring_repeats, measured_values, measurement_row

KEYS = ("car", "taken_at")
LONG = ("parameter", "value")
EXAMPLE = "car,taken_at,brake_cylinder_fill_s,door_close_s"
_SHOWN = 5  # errors listed before "… and N more"
_INSERT_CHUNK = 1000
# A number as a CSV of measurements writes it: ASCII digits, an optional sign, point and
# exponent. ``float`` also reads ``3.1_0``, Arabic-Indic or full-width digits; those are refused.
_DECIMAL = re.compile(r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?", re.ASCII)
_BLANKS = " \t"

Test = tuple[str, datetime, dict[str, float]]


def _when(text: str, line: int, errors: list[str], now: datetime) -> datetime | None:
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
    ahead = ahead_problem(at, now)
    if ahead:
        errors.append(f"line {line}: {ahead}")
        return None
    return at


def _number(text: str, line: int, column: str, errors: list[str]) -> float | None:
    written = text.strip(_BLANKS)
    value = float(written) if _DECIMAL.fullmatch(written) else math.nan
    if not math.isfinite(value):
        errors.append(
            f"line {line}, column {column}: {text!r} is not a finite number in ASCII decimal"
            " digits; write it like 3.1, -0.25 or 2.4e-3"
        )
        return None
    return value


def _shape_problem(fields: list[str], line: int, width: int) -> str | None:
    if len(fields) > width:
        return (
            f"line {line}: {len(fields)} fields for {width} columns — a decimal comma?"
            " write 3.1 with a point, or quote the field"
        )
    if len(fields) < width:
        return f"line {line}: fewer fields than the {width} columns of the header"
    return None


def _unknown_columns(params: list[str], parameters: Mapping[str, Parameter]) -> list[str]:
    unknown = {name: 0.0 for name in params if name not in parameters}
    return [f"column {name}: {why}" for name, why in value_problems(parameters, unknown).items()]


def _header(reader: Iterator[list[str]]) -> list[str]:
    header = [name.strip() for name in next(reader, [])]
    if len(header) == 1 and ";" in header[0]:
        raise Unprocessable(
            "the header is separated by ';' (the CSV of a decimal-comma locale); export it"
            f" with ',' between fields and '.' in numbers, like {EXAMPLE}"
        )
    missing = [key for key in KEYS if key not in header]
    if missing:
        raise Unprocessable(
            f"the CSV lacks the column(s) {', '.join(missing)}; the first line must be a header"
            f" like {EXAMPLE} (or car,taken_at,parameter,value)"
        )
    repeated = sorted({name for name in header if name and header.count(name) > 1})
    if repeated:
        # Two cells under one name: which is the test's value is unknown, so nothing is read.
        raise Unprocessable(
            f"line 1 names the column(s) {', '.join(repeated)} more than once; give each"
            " parameter one column"
        )
    return header


@dataclass
class _Parsed:
    """What the rows held: each test's values with the line of every value, and the errors."""

    errors: list[str] = field(default_factory=list)
    tests: dict[tuple[str, datetime], dict[str, tuple[float, int]]] = field(default_factory=dict)

    def add(self, car: str, at: datetime, values: Mapping[str, float], line: int) -> None:
        """Merge a row's values into its test; a value contradicting an earlier row's is an
        error naming both lines (the same value again, or other parameters, merge)."""
        test = self.tests.setdefault((car, at), {})
        for name, value in values.items():
            before = test.get(name)
            if before is not None and before[0] != value:
                self.errors.append(
                    f"lines {before[1]} and {line}: car {car} at {at.isoformat()} has"
                    f" {name} = {before[0]:g} and {value:g}; keep the right one"
                )
                continue
            test.setdefault(name, (value, line))


def parse_tests(
    stream: TextIO, parameters: Mapping[str, Parameter], now: datetime | None = None
) -> list[Test]:
    """The tests in a CSV file, checked against the registered ``parameters`` and the server
    time ``now`` (default: the clock); raises Unprocessable listing the bad lines and columns
    (nothing is imported then)."""
    now = utcnow() if now is None else now
    reader = csv.reader(stream)
    header = _header(reader)
    rows = [(line, fields) for line, fields in enumerate(reader, start=2) if fields]
    long = set(LONG) <= set(header)
    params = [name for name in header if name not in KEYS and name]
    parsed = _Parsed(errors=[] if long else _unknown_columns(params, parameters))
    parsed.errors.extend(decimal_comma_problems(header, rows, numeric=[] if long else params))
    for line, fields in rows:
        shape = _shape_problem(fields, line, len(header))
        if shape:
            parsed.errors.append(shape)
            continue
        row = dict(zip(header, fields, strict=True))
        _parse_row(row, line, long, params, parameters, parsed, now)
    _raise(parsed.errors, "fix these lines and import the file again (nothing was imported)")
    if not parsed.tests:
        raise Unprocessable("the CSV holds no measurements; add rows under the header")
    return [
        (car, at, {name: value for name, (value, _) in values.items()})
        for (car, at), values in parsed.tests.items()
    ]


def _parse_row(
    row: dict[str, str],
    line: int,
    long: bool,
    params: list[str],
    parameters: Mapping[str, Parameter],
    parsed: _Parsed,
    now: datetime,
) -> None:
    errors = parsed.errors
    car, at = (row.get("car") or "").strip(), _when(row.get("taken_at") or "", line, errors, now)
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
        parsed.add(car, at, values, line)


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
    statement = insert_ignoring_repeats(session).returning(Measurement.car_id, Measurement.taken_at)
    written: set[tuple[str, datetime]] = set()
    for start in range(0, len(rows), _INSERT_CHUNK):
        chunk = rows[start : start + _INSERT_CHUNK]
        written.update((car, at) for car, at in session.connection().execute(statement, chunk))
    if len(written) < len(rows):
        # A concurrent import stored some of these tests after the check: the same values
        # are skipped, other values refuse the whole file as any conflict does.
        _raise(_already_stored(session, tests)[1], "correct the file or the stored tests"
               " (nothing was imported)")  # fmt: skip
    session.flush()
    done = [(car, at, v) for car, at, v in tests if (car, at) in written]
    return len(done), sum(len(v) for _, _, v in done)
