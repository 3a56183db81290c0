"""The tests of a measurement CSV as compactly as the import must remember them.

The import refuses a file whose rows contradict each other (one car, time and parameter with
two values, naming both lines), and rows of one test may be anywhere in the file; so every
test's values, with the line each was first read on, are kept until the file ends — and no
more than that: no row, no dict per test.
"""

from __future__ import annotations

import struct
from collections.abc import Iterable, Iterator, Mapping
from datetime import datetime, timedelta, tzinfo

from ingest.field_types import EARLIEST, LATEST

Test = tuple[str, datetime, dict[str, float]]

# One value of a test: its parameter's number, the line it was read on, the value.
_ENTRY = struct.Struct("<IId")
_MICROSECOND = timedelta(microseconds=1)
_TIME_BITS = 52  # microseconds from EARLIEST to LATEST (a century) fit in 2**52


class TestBook:
    """The tests of a file, as compactly as the contradiction check and the insert need them.

    Per test: one int key (car number and instant) in an index, the first row's offset, and
    one packed entry per value (parameter, first line, value) — no row, no dict per test. Rows
    of one test anywhere in the file merge into it; the same instant written with another
    offset is the same test. Iterating gives the tests in the order first read.
    """

    __test__ = False  # not a pytest class, whatever its name says

    def __init__(self) -> None:
        self._cars: dict[str, int] = {}
        self._names: dict[str, int] = {}
        self._zones: dict[tzinfo, int] = {}
        self._index: dict[int, int] = {}  # key → test number
        self._zone_of: list[int] = []
        self._entries: list[bytes] = []
        self._names_by_number: list[str] = []

    def __len__(self) -> int:
        return len(self._entries)

    def cars(self) -> set[str]:
        return set(self._cars)

    def add(self, car: str, at: datetime, values: Mapping[str, float], line: int) -> list[str]:
        """Merge a row's values into its test; returns the errors of values contradicting an
        earlier row's, naming both lines (the same value again, or other parameters, merge)."""
        car_number = self._cars.setdefault(car, len(self._cars))
        key = self._key(car_number, at)
        number = self._index.setdefault(key, len(self._entries))
        if number == len(self._entries):
            assert at.tzinfo is not None  # checked by _when
            self._zone_of.append(self._zones.setdefault(at.tzinfo, len(self._zones)))
            self._entries.append(self._packed(values.items(), line))
            return []
        held = {p: (first, value) for p, first, value in _ENTRY.iter_unpack(self._entries[number])}
        errors, added = [], {}
        for name, value in values.items():
            before = held.get(self._names.setdefault(name, len(self._names)))
            if before is None:
                added[name] = value
            elif before[1] != value:
                errors.append(
                    f"lines {before[0]} and {line}: car {car} at {at.isoformat()} has"
                    f" {name} = {before[1]:g} and {value:g}; keep the right one"
                )
        if added:
            self._entries[number] += self._packed(added.items(), line)
        return errors

    def _packed(self, values: Iterable[tuple[str, float]], line: int) -> bytes:
        names = self._names
        pack = _ENTRY.pack
        return b"".join(pack(names.setdefault(name, len(names)), line, v) for name, v in values)

    def _key(self, car_number: int, at: datetime) -> int:
        return car_number << _TIME_BITS | (at - EARLIEST) // _MICROSECOND

    def find(self, car: str, at: datetime) -> int | None:
        """The number of the car's test at ``at`` (any offset), None when the file has none."""
        car_number = self._cars.get(car)
        if car_number is None or not EARLIEST <= at < LATEST:  # a file's test never is
            return None
        return self._index.get(self._key(car_number, at))

    def values_of(self, number: int) -> dict[str, float]:
        names = self._name_list()
        return {names[p]: v for p, _, v in _ENTRY.iter_unpack(self._entries[number])}

    def _name_list(self) -> list[str]:
        if len(self._names_by_number) != len(self._names):
            self._names_by_number = list(self._names)
        return self._names_by_number

    def __iter__(self) -> Iterator[Test]:
        cars, zones = list(self._cars), list(self._zones)
        low = (1 << _TIME_BITS) - 1
        for key, number in self._index.items():
            at = (EARLIEST + (key & low) * _MICROSECOND).astimezone(zones[self._zone_of[number]])
            yield cars[key >> _TIME_BITS], at, self.values_of(number)
