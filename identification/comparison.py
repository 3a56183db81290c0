"""Comparing a run's departure and arrival consists (spec §5; clearance.md).

Public entry point: :func:`identification.consist.compare_consists` (re-exported there).
Cars keep their order in a train, so the consists are aligned in order (a small dynamic
programme, like a diff) before anything is concluded.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Literal

__all__ = ["ConsistComparison", "compare_consists"]

Mark = Literal["same", "missing", "unknown", "extra"]
ConsistStatus = Literal["identical", "missing", "unknown"]
Row = tuple[str | None, str | None, Mark]
Place = tuple[int, str | None]  # (1-based position, car id or None)


@dataclass(frozen=True)
class ConsistComparison:
    """Departure vs arrival consist.

    Attributes
    ----------
    status : {"identical", "missing", "unknown"}
        ``identical``: same cars, same order, all identified. ``missing``: one or more
        departure cars are proven absent at arrival (the arrival has fewer cars, or a
        departure car is not among the arrival cars while every arrival car is identified).
        ``unknown``: anything else (unidentified positions, extra or reordered cars): the
        consists prove nothing.
    missing : list of (int, str or None)
        (departure position, car id) of the missing cars, car None for an unidentified one;
        non-empty exactly when ``status == "missing"``.
    unknown_positions : list of int
        Departure positions that could not be decided.
    aligned : list of (str or None, str or None, str)
        (departure car, arrival car, mark) rows for a car-by-car display; mark is ``same``,
        ``missing``, ``unknown`` or ``extra``.
    reason : str
        In a dispatcher's words, e.g. "arrival consist lacks cars 0412, 0413 (positions 11–12)".
    extra : list of (int, str or None)
        (arrival position, car id) of arrival cars matched to no departure car.
    """

    status: ConsistStatus
    missing: list[Place]
    unknown_positions: list[int]
    aligned: list[Row]
    reason: str
    extra: list[Place] = field(default_factory=list)


def _ranges(positions: Sequence[int]) -> str:
    """``[11, 12, 15]`` → ``"positions 11–12, 15"``."""
    ps = sorted(positions)
    parts: list[str] = []
    k = 0
    while k < len(ps):
        j = k
        while j + 1 < len(ps) and ps[j + 1] == ps[j] + 1:
            j += 1
        parts.append(str(ps[k]) if j == k else f"{ps[k]}–{ps[j]}")
        k = j + 1
    return ("position " if len(ps) == 1 else "positions ") + ", ".join(parts)


def _cars(ids: Sequence[str | None], adjective: str = "") -> str:
    names = [c if c is not None else "(unidentified)" for c in ids]
    noun = "car " if len(names) == 1 else "cars "
    return (adjective + " " if adjective else "") + noun + ", ".join(names)


def _pair_score(a: str | None, b: str | None) -> int | None:
    """Two identified cars pair only if they are the same car; an unknown side is compatible."""
    if a is None or b is None:
        return 1
    return 3 if a == b else None


def _align(
    dep: Sequence[str | None], arr: Sequence[str | None]
) -> list[tuple[int | None, int | None]]:
    """Order-preserving alignment (index pairs, None = gap) maximising agreement; on ties the
    unmatched departure cars go to the rear (a lost rear part is the usual case)."""
    n, m = len(dep), len(arr)
    score = [[0] * (m + 1) for _ in range(n + 1)]
    for i in range(1, n + 1):
        row, prev = score[i], score[i - 1]
        for j in range(1, m + 1):
            p = _pair_score(dep[i - 1], arr[j - 1])
            row[j] = max(prev[j], row[j - 1], -1 if p is None else prev[j - 1] + p)
    out: list[tuple[int | None, int | None]] = []
    i, j = n, m
    while i > 0 or j > 0:
        p = _pair_score(dep[i - 1], arr[j - 1]) if i > 0 and j > 0 else None
        if i > 0 and score[i][j] == score[i - 1][j]:
            out.append((i - 1, None))
            i -= 1
        elif p is not None and score[i][j] == score[i - 1][j - 1] + p:
            out.append((i - 1, j - 1))
            i, j = i - 1, j - 1
        else:
            out.append((None, j - 1))
            j -= 1
    out.reverse()
    return out


@dataclass
class _Tally:
    rows: list[Row] = field(default_factory=list)
    missing: list[Place] = field(default_factory=list)
    unproven: list[Place] = field(default_factory=list)
    unknown: list[int] = field(default_factory=list)
    extra: list[Place] = field(default_factory=list)


def _tally(dep: list[str | None], arr: list[str | None]) -> _Tally:
    known_arr = {a for a in arr if a is not None}
    fewer = len(arr) < len(dep)
    all_known = None not in arr
    pairs = _align(dep, arr)
    gaps = [(di, dep[di]) for di, ai in pairs if di is not None and ai is None]
    # a departure car with no partner is proven missing when the arrival has fewer cars or
    # every arrival car is identified — unless it is present elsewhere (reordered)
    absent = {di for di, d in gaps if d is None or d not in known_arr}
    if fewer and not absent:
        absent = {di for di, _ in gaps}
    proven = absent if fewer or all_known else set()
    t = _Tally()
    for di, ai in pairs:
        d = dep[di] if di is not None else None
        a = arr[ai] if ai is not None else None
        if di is not None and ai is not None:
            t.rows.append((d, a, "same" if d is not None and a is not None else "unknown"))
            if d is None or a is None:
                t.unknown.append(di + 1)
        elif di is not None:
            mark: Mark = "missing" if di in proven else "unknown"
            t.rows.append((d, None, mark))
            (t.missing if di in proven else t.unproven).append((di + 1, d))
            if di not in proven:
                t.unknown.append(di + 1)
        elif ai is not None:
            t.rows.append((None, a, "extra"))
            t.extra.append((ai + 1, a))
    return t


def _extra_words(t: _Tally, dep: list[str | None]) -> list[str]:
    dep_known = {d for d in dep if d is not None}
    unproven_cars = {c for _, c in t.unproven}
    strangers = [(p, c) for p, c in t.extra if c is None or c not in dep_known]
    shuffled = [(p, c) for p, c in t.extra if c in dep_known and c not in unproven_cars]
    words: list[str] = []
    if strangers:
        words.append(
            f"arrival consist has {_cars([c for _, c in strangers], 'extra')} "
            f"({_ranges([p for p, _ in strangers])}) not in the departure consist"
        )
    if shuffled:
        words.append(
            f"arrival {_cars([c for _, c in shuffled])} "
            f"(arrival {_ranges([p for p, _ in shuffled])}) out of the departure order"
        )
    return words


def _unidentified_words(t: _Tally, paired: list[int]) -> list[str]:
    """Paired positions with an unidentified car, naming the side that lacked it ("not
    identified on both sides" was read as "on neither" or "on one": an independent trial)."""
    rows = [r for r in t.rows if r[2] != "extra"]  # one per departure position, in order
    sides: dict[str, list[int]] = {"departure": [], "arrival": [], "neither": []}
    for p in paired:
        dep, arr, _ = rows[p - 1]
        sides[
            "neither" if dep is None and arr is None else "arrival" if dep else "departure"
        ].append(p)
    words = []
    for p in sides["departure"]:
        words.append(
            f"departure {_ranges([p])} not identified at departure (arrival: car {rows[p - 1][1]})"
        )
    for p in sides["arrival"]:
        words.append(
            f"departure {_ranges([p])} not identified on arrival (departure: car {rows[p - 1][0]})"
        )
    if sides["neither"]:
        words.append(f"departure {_ranges(sides['neither'])} identified on neither side")
    return words


def _unknown_words(t: _Tally, arr: list[str | None]) -> list[str]:
    known_arr = {a for a in arr if a is not None}
    unproven_pos = {p for p, _ in t.unproven}
    paired = [p for p in t.unknown if p not in unproven_pos]
    words = _unidentified_words(t, paired)
    for p, c in t.unproven:
        where = f"{_cars([c])} (departure {_ranges([p])})"
        if c is not None and c in known_arr:
            words.append(f"{where} arrived out of the departure order")
        else:
            n = sum(a is None for a in arr)
            words.append(
                f"{where} not found among the identified arrival cars, "
                f"but {n} arrival car(s) are unidentified"
            )
    return words


def compare_consists(
    departure: Sequence[str | None], arrival: Sequence[str | None]
) -> ConsistComparison:
    """Compare a run's departure and arrival consists.

    Parameters
    ----------
    departure, arrival : sequence of str or None
        Car ids in passing order (head first), None for a position that was read but not
        identified. An empty consist (nothing read) proves nothing.

    Returns
    -------
    ConsistComparison
        ``status`` identical / missing / unknown, the missing cars with their departure
        positions, the undecided positions, the aligned rows and the reason in plain words.
    """
    dep, arr = list(departure), list(arrival)
    if not dep or not arr:
        side = "departure" if not dep else "arrival"
        rows: list[Row] = [(d, None, "unknown") for d in dep]
        rows += [(None, a, "unknown") for a in arr]
        reason = f"no {side} consist was read: the consists prove nothing"
        return ConsistComparison("unknown", [], list(range(1, len(dep) + 1)), rows, reason)
    t = _tally(dep, arr)
    extra_words = _extra_words(t, dep)
    if t.missing:
        words = [
            f"arrival consist lacks {_cars([c for _, c in t.missing])} "
            f"({_ranges([p for p, _ in t.missing])})"
        ]
        n_unknown = sum(a is None for a in arr)
        if len(arr) < len(dep) and n_unknown:
            words.append(
                f"{len(arr)} cars arrived of {len(dep)} departed, {n_unknown} of them unidentified"
            )
        reason = "; ".join(words + extra_words)
        return ConsistComparison("missing", t.missing, t.unknown, t.rows, reason, t.extra)
    if not t.unknown and not t.extra:
        reason = f"arrival consist identical to departure ({len(dep)} cars)"
        return ConsistComparison("identical", [], [], t.rows, reason)
    words = _unknown_words(t, arr) + extra_words
    reason = "; ".join(words) + ": completeness cannot be proven from the consists"
    return ConsistComparison("unknown", [], t.unknown, t.rows, reason, t.extra)
