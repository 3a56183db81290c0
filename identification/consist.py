"""Consists: the ordered cars of one train passing one reader, and their comparison (spec §5).

- :func:`majority_number` — strict majority of repeated IR reads.
- :func:`identify_car` / :func:`assemble_consist` — reads of one passage (wheel code and/or IR
  number per car, in passing order) → a :class:`Consist`, mapped through the car registry;
  reads that map to no car are kept as unknown positions, a wheel/IR disagreement is reported.
- :func:`compare_consists` — departure vs arrival: ``identical`` / ``missing`` / ``unknown``,
  with the missing cars and positions, an aligned car-by-car view and a plain-words reason.
- :func:`axle_sum` / :func:`compare_axles` — axle counts of a consist and their comparison.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Literal

from identification.comparison import ConsistComparison, compare_consists

__all__ = [
    "AxleComparison",
    "CarRead",
    "Consist",
    "ConsistComparison",
    "ConsistEntry",
    "assemble_consist",
    "axle_sum",
    "combine_reads",
    "compare_axles",
    "compare_consists",
    "identify_car",
    "majority_number",
]


def majority_number(reads: Sequence[int]) -> int | None:
    """The strict majority of repeated reads (an ``ir_id`` event's ``reads``).

    Parameters
    ----------
    reads : sequence of int
        Car numbers read while the car was in the zone.

    Returns
    -------
    int or None
        The number read more often than all others together, else None.
    """
    if not reads:
        return None
    value, count = Counter(reads).most_common(1)[0]
    return value if 2 * count > len(reads) else None


# ---------------------------------------------------------------------------------------------
# Assembling a passage into a consist
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class CarRead:
    """What the readers made of one car passage (None: that technology gave nothing)."""

    wheel_code: int | None = None
    ir_number: int | None = None


EntryStatus = Literal["identified", "unregistered", "conflict", "unread"]


@dataclass(frozen=True)
class ConsistEntry:
    """One position of a consist: the car (None if unknown), how it was identified
    (``identified``, ``unregistered``, ``conflict`` or ``unread``), the raw reads and a note."""

    position: int  # 1-based, in passing order
    car: str | None  # the registered car, None for an unknown position
    status: EntryStatus
    wheel_code: int | None = None
    ir_number: int | None = None
    note: str = ""


@dataclass(frozen=True)
class Consist:
    """The cars of one train passing one reader, in passing order."""

    entries: list[ConsistEntry]
    direction: int | None = None
    notes: list[str] = field(default_factory=list)

    @property
    def car_ids(self) -> list[str | None]:
        """The cars in order, None where the position is unknown."""
        return [e.car for e in self.entries]

    @property
    def conflicts(self) -> list[ConsistEntry]:
        return [e for e in self.entries if e.status == "conflict"]


def identify_car(
    read: CarRead,
    *,
    wheel_codes: Mapping[int, str],
    ir_numbers: Mapping[int, str],
    position: int = 1,
) -> ConsistEntry:
    """Map one car's reads to a registered car.

    Both technologies must agree: when they name different cars, or one names a car whose own
    registered code differs from what the other technology read, the position is a
    ``conflict`` (car None). A read that maps to no car is kept (``unregistered``), not dropped.

    Parameters
    ----------
    read : CarRead
        The wheel code and/or IR number read for the car.
    wheel_codes, ir_numbers : mapping of int to str
        The car registry: code → car id.
    position : int
        1-based position in the consist.

    Returns
    -------
    ConsistEntry
        The car (or None), the status and a note; the raw reads are kept.
    """
    w, i = read.wheel_code, read.ir_number
    w_car = wheel_codes.get(w) if w is not None else None
    i_car = ir_numbers.get(i) if i is not None else None

    def entry(car: str | None, status: EntryStatus, note: str = "") -> ConsistEntry:
        return ConsistEntry(position, car, status, w, i, note)

    if w is None and i is None:
        return entry(None, "unread", "no read")
    if w_car is not None and i_car is not None:
        if w_car != i_car:
            return entry(None, "conflict", f"wheel marks say {w_car}, infrared says {i_car}")
        return entry(w_car, "identified")
    if w_car is not None or i_car is not None:
        car = w_car if w_car is not None else i_car
        assert car is not None
        # the other technology read something that maps to no car: does the car have a
        # registered code of that technology that it contradicts?
        if w_car is None and w is not None and car in wheel_codes.values():
            return entry(None, "conflict", f"infrared says {car}, wheel code {w} is no car's")
        if i_car is None and i is not None and car in ir_numbers.values():
            return entry(None, "conflict", f"wheel marks say {car}, IR number {i} is no car's")
        return entry(car, "identified")
    parts = []
    if w is not None:
        parts.append(f"wheel code {w}")
    if i is not None:
        parts.append(f"IR number {i}")
    return entry(None, "unregistered", " and ".join(parts) + " map to no registered car")


def combine_reads(
    wheel_codes: Sequence[int | None] | None = None,
    ir_numbers: Sequence[int | None] | None = None,
) -> tuple[list[CarRead], list[str]]:
    """Pair the wheel-mark and IR reads of one train at one reader by position.

    Parameters
    ----------
    wheel_codes, ir_numbers : sequence of int or None, optional
        Codes in passing order (None: that car gave no code).

    Returns
    -------
    reads : list of CarRead
        One per position (the longer list sets the length).
    notes : list of str
        A note when the two readers saw different numbers of cars.
    """
    w = list(wheel_codes or [])
    r = list(ir_numbers or [])
    notes: list[str] = []
    if w and r and len(w) != len(r):
        notes.append(f"wheel-mark reader saw {len(w)} cars, infrared reader {len(r)}")
    n = max(len(w), len(r))
    reads = [CarRead(w[k] if k < len(w) else None, r[k] if k < len(r) else None) for k in range(n)]
    return reads, notes


def assemble_consist(
    reads: Sequence[CarRead],
    *,
    wheel_codes: Mapping[int, str],
    ir_numbers: Mapping[int, str],
    direction: int | None = None,
) -> Consist:
    """The consist of one passage: one entry per car read, in passing order.

    Parameters
    ----------
    reads : sequence of CarRead
        In passing order.
    wheel_codes, ir_numbers : mapping of int to str
        The car registry: code → car id.
    direction : int, optional
        Direction of passage, kept on the consist.

    Returns
    -------
    Consist
        Entries with positions 1…n; conflicts listed in ``notes``.
    """
    entries = [
        identify_car(r, wheel_codes=wheel_codes, ir_numbers=ir_numbers, position=k)
        for k, r in enumerate(reads, 1)
    ]
    notes = [f"position {e.position}: {e.note}" for e in entries if e.status == "conflict"]
    return Consist(entries=entries, direction=direction, notes=notes)


# ---------------------------------------------------------------------------------------------
# Axle counts
# ---------------------------------------------------------------------------------------------


def axle_sum(
    cars: Sequence[str | None],
    axles_per_car: Mapping[str, int],
    *,
    default_axles: int | None = None,
) -> int | None:
    """Sum of the axles of a consist's cars.

    Parameters
    ----------
    cars : sequence of str or None
        Car ids of the consist, None for an unknown position.
    axles_per_car : mapping of str to int
        Axles of each registered car.
    default_axles : int, optional
        Axles counted for an unknown position or an unregistered car.

    Returns
    -------
    int or None
        The sum; None when a car's axles are unknown and there is no default.
    """
    total = 0
    for car in cars:
        n = axles_per_car.get(car) if car is not None else None
        if n is None:
            if default_axles is None:
                return None
            n = default_axles
        total += n
    return total


AxleStatus = Literal["equal", "fewer", "more", "unknown"]


@dataclass(frozen=True)
class AxleComparison:
    """Arrival axle count compared with the departure count."""

    status: AxleStatus  # arrival compared with departure
    difference: int | None  # arrival − departure
    reason: str


def compare_axles(departure: int | None, arrival: int | None) -> AxleComparison:
    """Compare departure and arrival axle counts (fewer at arrival proves a loss).

    Parameters
    ----------
    departure, arrival : int or None
        Axle counts (axle counters, or :func:`axle_sum` of the consists); None if missing.

    Returns
    -------
    AxleComparison
        ``status`` of the arrival: ``equal``, ``fewer``, ``more`` or ``unknown``.
    """
    if departure is None or arrival is None:
        side = "departure" if departure is None else "arrival"
        return AxleComparison("unknown", None, f"no {side} axle count")
    diff = arrival - departure
    if diff == 0:
        return AxleComparison("equal", 0, f"{arrival} axles at both ends")
    if diff < 0:
        return AxleComparison(
            "fewer", diff, f"{arrival} axles arrived of {departure} departed ({-diff} missing)"
        )
    return AxleComparison("more", diff, f"{arrival} axles arrived, {departure} departed")
