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

The file is streamed: no row is kept, only what the checks must remember — each test's values
with the line of each (`service.fleet.testbook`, compactly) and the first errors of each kind
with a count. The stored tests of the file's cars are read a chunk at a time and looked up in
the book; the new tests are inserted a chunk at a time in the caller's transaction, and a
refusal rolls back what earlier chunks wrote (a savepoint), so it is still all rows or none.
"""

from __future__ import annotations

import csv
import math
import re
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from datetime import datetime
from itertools import islice
from typing import TextIO

from sqlalchemy import select
from sqlalchemy.orm import Session

from core.database import utcnow
from core.errors import Unprocessable
from core.models import Car
from ingest.field_types import EARLIEST, LATEST
from service.fleet.csv_checks import DecimalCommaCheck, FirstErrors
from service.fleet.models import Measurement, MeasurementLayout, Parameter, decode_readings
from service.fleet.rules import ahead_problem, plausible_range, value_problems
from service.fleet.service import insert_ignoring_repeats, measurement_row, stored_test
from service.fleet.testbook import Test, TestBook

KEYS = ("car", "taken_at")
LONG = ("parameter", "value")
EXAMPLE = "car,taken_at,brake_cylinder_fill_s,door_close_s"
# A number as a CSV of measurements writes it: ASCII digits, an optional sign, point and
# exponent. ``float`` also reads ``3.1_0``, Arabic-Indic or full-width digits; those are refused.
_DECIMAL = re.compile(r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?", re.ASCII)
_BLANKS = " \t"
_FIX_LINES = "fix these lines and import the file again (nothing was imported)"
_FIX_STORED = "correct the file or the stored tests (nothing was imported)"


@dataclass(frozen=True)
class ImportLimits:
    """Tunables of the CSV import.

    Attributes
    ----------
    shown : int
        Errors listed in a refusal before "… and N more" (the others are only counted).
    chunk : int
        Tests checked against the stored ones and inserted at a time: bounds the insert rows
        and stored tests held at once (and a query's bound parameters, two per test).
    """

    shown: int = 5
    chunk: int = 1000


LIMITS = ImportLimits()


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


@dataclass(frozen=True)
class _Rows:
    """What reading a row needs: the layout and its columns, the registered parameters and
    their plausible ranges (looked up once: a value in its range needs no words), the book and
    the server time."""

    long: bool
    car: int  # the columns, by their place in the header
    taken_at: int
    cells: list[tuple[str, int]]  # the value columns of a wide file; parameter, value of a long
    parameters: Mapping[str, Parameter]
    ranges: dict[str, tuple[float, float]]
    book: TestBook
    now: datetime


def read_tests(
    stream: TextIO, parameters: Mapping[str, Parameter], now: datetime | None = None
) -> TestBook:
    """The tests in a CSV file, read row by row and checked against the registered
    ``parameters`` and the server time ``now`` (default: the clock); raises Unprocessable
    listing the bad lines and columns (nothing is imported then)."""
    reader = csv.reader(stream)
    header = _header(reader)
    long = set(LONG) <= set(header)
    params = [name for name in header if name not in KEYS and name]
    ranges = {name: plausible_range(parameter) for name, parameter in parameters.items()}
    where = {name: i for i, name in enumerate(header)}
    cells = [(name, where[name]) for name in (LONG if long else params)]
    now = utcnow() if now is None else now
    at = _Rows(long, where["car"], where["taken_at"], cells, parameters, ranges, TestBook(), now)
    found = FirstErrors(LIMITS.shown)
    found.extend([] if long else _unknown_columns(params, parameters))
    commas = DecimalCommaCheck(header, numeric=[] if long else params, limit=LIMITS.shown)
    rows = FirstErrors(LIMITS.shown)
    for line, fields in enumerate(reader, start=2):
        if not fields:
            continue
        commas.row(line, fields)
        shape = _shape_problem(fields, line, len(header))
        if shape:
            rows.add(shape)
            continue
        rows.extend(_parse_row(at, fields, line))
    kinds = [found, commas.unnamed, commas.split_pairs(), rows]
    _raise(FirstErrors.joined(kinds, LIMITS.shown), _FIX_LINES)
    if not at.book:
        raise Unprocessable("the CSV holds no measurements; add rows under the header")
    return at.book


def parse_tests(
    stream: TextIO, parameters: Mapping[str, Parameter], now: datetime | None = None
) -> list[Test]:
    """:func:`read_tests` as a list of tests (a small file's; the import keeps the book)."""
    return list(read_tests(stream, parameters, now))


def _parse_row(at: _Rows, fields: list[str], line: int) -> list[str]:
    """The row's errors, in the order its cells are read; its values go into the book."""
    errors: list[str] = []
    car = fields[at.car].strip()
    when = _when(fields[at.taken_at], line, errors, at.now)
    if not car:
        errors.append(f"line {line}: the car is empty")
    if at.long:
        name = fields[at.cells[0][1]].strip()
        if not name:
            errors.append(f"line {line}: the parameter is empty")
        cells = [(name, fields[at.cells[1][1]])] if name else []
    else:
        cells = [(name, fields[i]) for name, i in at.cells]
    values = {}
    for name, text in cells:
        if text.strip():
            value = _number(text, line, name if not at.long else "value", errors)
            if value is not None:
                values[name] = value
    ranges = at.ranges
    if not all(name in ranges and _within(value, ranges[name]) for name, value in values.items()):
        refused = value_problems(at.parameters, values)
        if not at.long:  # unknown columns were reported once, from the header
            refused = {k: v for k, v in refused.items() if k in at.parameters}
        errors.extend(f"line {line}, column {name}: {why}" for name, why in refused.items())
    if car and when is not None and values:
        errors.extend(at.book.add(car, when, values, line))
    return errors


def _within(value: float, limits: tuple[float, float]) -> bool:
    return limits[0] <= value <= limits[1]


def _raise(errors: FirstErrors, fix: str) -> None:
    if errors.count:
        more = f"; … and {errors.count - errors.limit} more" if errors.count > errors.limit else ""
        raise Unprocessable(f"{'; '.join(errors.shown)}{more} — {fix}")


def _refuse_unknown_cars(session: Session, cars: set[str]) -> None:
    known = set(session.scalars(select(Car.id).where(Car.id.in_(cars))))
    unknown = sorted(cars - known)
    if unknown:
        listed = ", ".join(unknown[:10]) + (" …" if len(unknown) > 10 else "")
        raise Unprocessable(
            f"unknown car(s) {listed}; register them (POST /api/v1/cars) or correct the car"
            " column, then import again (nothing was imported)"
        )


def import_tests(session: Session, tests: TestBook) -> tuple[int, int]:
    """Store the read tests (source ``csv``), one row each; returns (tests, values) stored.

    Tests already stored with the same values are skipped (a re-import stores nothing); a
    stored test with other values refuses the file. The new tests are inserted a chunk at a
    time; a refusal rolls back what earlier chunks wrote (a savepoint, whatever the caller
    does with the error).
    """
    _refuse_unknown_cars(session, tests.cars())
    marks = _stored_marks(session, tests)
    if _OTHER in marks:
        conflicts = FirstErrors(LIMITS.shown)
        for number, (car, at, _) in enumerate(tests):
            if marks[number] == _OTHER:
                conflicts.add(_conflict(car, at))
        _raise(conflicts, _FIX_STORED)
    with session.begin_nested():
        return _insert_new(session, tests, marks)


_NEW, _SAME, _OTHER = 0, 1, 2  # a test of the file: not stored, stored as it is, stored otherwise


def _conflict(car: str, at: datetime) -> str:
    return f"car {car} at {at.isoformat()} is stored with other values"


def _stored_marks(session: Session, tests: TestBook) -> bytearray:
    """Per test of the file, whether it is stored (``_NEW``, ``_SAME``, ``_OTHER``): the stored
    tests of the file's cars are read a chunk at a time, each looked up in the book."""
    marks = bytearray(len(tests))
    layouts = session.execute(select(MeasurementLayout.id, MeasurementLayout.names))
    names = {layout: layout_names for layout, layout_names in layouts}
    columns = (Measurement.car_id, Measurement.taken_at, Measurement.layout_id)
    query = select(*columns, Measurement.readings).where(Measurement.car_id.in_(tests.cars()))
    stored = session.execute(query.execution_options(yield_per=LIMITS.chunk))
    for rows in stored.partitions():
        for car, at, layout, readings in rows:
            number = tests.find(car, at)
            if number is not None:
                values = dict(zip(names[layout], decode_readings(readings), strict=True))
                marks[number] = _SAME if values == tests.values_of(number) else _OTHER
    return marks


def _insert_new(session: Session, tests: TestBook, marks: bytearray) -> tuple[int, int]:
    layouts: dict[str, int] = {}
    statement = insert_ignoring_repeats(session).returning(Measurement.car_id, Measurement.taken_at)
    conflicts = FirstErrors(LIMITS.shown)
    done = values = 0
    each = (test for number, test in enumerate(tests) if marks[number] == _NEW)
    while new := list(islice(each, LIMITS.chunk)):
        rows = [measurement_row(session, c, at, v, source="csv", known=layouts) for c, at, v in new]
        written = {(car, at) for car, at in session.connection().execute(statement, rows)}
        for car, at, test in new:
            if (car, at) in written:
                done, values = done + 1, values + len(test)
            elif stored_test(session, car, at) != test:
                # A concurrent import stored this test after the check: the same values are
                # skipped, other values refuse the whole file as any conflict does.
                conflicts.add(_conflict(car, at))
    _raise(conflicts, _FIX_STORED)
    session.flush()
    return done, values
