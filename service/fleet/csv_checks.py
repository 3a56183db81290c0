"""Signs that a measurement CSV was written with decimal commas although its rows still have
as many fields as the header has columns.

A decimal comma that adds a field is caught by the field count. It escapes that check when
the number's fraction lands in a cell that would otherwise be empty: ``2,45`` under
``door_close_s,brake_release_s`` reads as door 2 s and brake 45 s, and an exported header
with a trailing separator hides the fraction in a column without a name. Both are wrong
numbers, not wear, so the import is refused with the line and the columns named.

The import streams its file, so the check reads one row at a time and keeps no rows: whether
a column writes its values with a point is known only at the end of the file, so a line whose
verdict depends on it is kept only while it may still be among the errors a refusal shows.
"""

from __future__ import annotations

import re
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

_WHOLE = re.compile(r"^[+-]?\d+$")  # how the integer part of a split number looks
_DIGITS = re.compile(r"^\d+$")  # how its fraction looks (no sign, no point, no exponent)
_FIX = "write decimals with a point (2.45), and a whole number as 2.0 in a file of decimals"


@dataclass
class FirstErrors:
    """Errors of one kind in the order found: the first ``limit`` worded, the rest counted —
    a refusal lists a few and says how many more, and a file of bad lines is never held."""

    limit: int
    shown: list[str] = field(default_factory=list)
    count: int = 0

    def add(self, error: str) -> None:
        self.count += 1
        if len(self.shown) < self.limit:
            self.shown.append(error)

    def extend(self, errors: Iterable[str]) -> None:
        for error in errors:
            self.add(error)

    @classmethod
    def joined(cls, kinds: Sequence[FirstErrors], limit: int) -> FirstErrors:
        """The kinds one after another, as if found in that order (each kind holds at least
        the ``limit`` first of its own, so the first ``limit`` of all are among them)."""
        shown = [error for kind in kinds for error in kind.shown][:limit]
        return cls(limit, shown, sum(kind.count for kind in kinds))


@dataclass(frozen=True)
class _Split:
    """A line's adjacent value cells that read as a split number, in header order, up to the
    first one that is certainly split (``sure``: a fraction like ``05``); which of the others
    is an error depends on whether its column writes decimals anywhere in the file."""

    line: int
    pairs: tuple[tuple[int, int, str, str, bool], ...]  # a, b, whole, fraction, sure


class DecimalCommaCheck:
    """Feed every row (:meth:`row`), then read the errors naming line and columns where a
    decimal comma was most likely split (:meth:`unnamed`, then :meth:`split_pairs`).

    Parameters
    ----------
    header : sequence of str
        The header's column names (stripped; an empty name is a column without a name).
    numeric : sequence of str
        The header's value columns of a wide file, in header order (empty for a long file).
    limit : int
        How many errors of each kind are worded; the rest are counted.
    """

    def __init__(self, header: Sequence[str], *, numeric: Sequence[str], limit: int) -> None:
        self._header = list(header)
        self._limit = limit
        self._blank = [i for i, name in enumerate(header) if not name]
        where = {name: i for i, name in enumerate(header)}
        self._positions = [where[name] for name in numeric]
        positions = self._positions
        self._pairs = [(a, b) for a, b in zip(positions, positions[1:], strict=False) if b == a + 1]
        self._pointed: set[int] = set()  # value columns written with a decimal point somewhere
        self._unpointed = list(positions)
        self.unnamed = FirstErrors(limit)
        self._sure = FirstErrors(limit)  # counts the certainly split lines; their _Split below
        self._sure_lines: list[_Split] = []
        # Lines split only if a column writes decimals: how many per set of such columns, and
        # each column's first few (enough for the first ``limit`` of the lines that are errors).
        self._maybe: Counter[frozenset[int]] = Counter()
        self._maybe_lines: dict[int, list[_Split]] = {}

    def row(self, line: int, fields: Sequence[str]) -> None:
        held = [i for i in self._blank if i < len(fields) and fields[i].strip()]
        if held:
            i = held[0]
            self.unnamed.add(
                f"line {line}, column {i + 1} (no name in the header): {fields[i].strip()!r}"
                f" — the fraction of a decimal comma? {_FIX}; or name the column"
            )
        if self._unpointed:  # soon empty: a file of decimals shows its points in a few rows
            found = {i for i in self._unpointed if i < len(fields) and "." in fields[i]}
            if found:
                self._pointed |= found
                self._unpointed = [i for i in self._unpointed if i not in found]
        pairs = self._split_candidates(fields)
        if not pairs:
            return
        split = _Split(line, tuple(pairs))
        if pairs[-1][4]:
            self._sure.add("")
            if len(self._sure_lines) < self._limit:
                self._sure_lines.append(split)
            return
        columns = frozenset(a for a, *_ in pairs)
        self._maybe[columns] += 1
        for a in columns:
            kept = self._maybe_lines.setdefault(a, [])
            if len(kept) < self._limit:
                kept.append(split)

    def _split_candidates(self, fields: Sequence[str]) -> list[tuple[int, int, str, str, bool]]:
        pairs = []
        for a, b in self._pairs:
            if b >= len(fields):
                continue
            whole, fraction = fields[a].strip(), fields[b].strip()
            if "." in whole or "." in fraction:  # a decimal: the common case, told at once
                continue
            if not (_WHOLE.match(whole) and _DIGITS.match(fraction)):
                continue
            # "05" is never how a number is written, only how a fraction is; otherwise a file
            # that writes this column's values with a point would not write a whole number
            # beside digits (known at the end of the file).
            sure = len(fraction) > 1 and fraction.startswith("0")
            pairs.append((a, b, whole, fraction, sure))
            if sure:
                break
        return pairs

    def split_pairs(self) -> FirstErrors:
        """The lines whose value cells read as one number split at a decimal comma (the first
        such pair of each line), once every row was fed."""
        pointed = self._pointed
        errors = FirstErrors(self._limit)
        errors.count = self._sure.count + sum(
            n for columns, n in self._maybe.items() if columns & pointed
        )
        kept = [*self._sure_lines, *(s for a in pointed for s in self._maybe_lines.get(a, []))]
        first = sorted({split.line: split for split in kept}.values(), key=lambda s: s.line)
        for split in first[: self._limit]:
            a, b, whole, fraction, _ = next(p for p in split.pairs if p[4] or p[0] in pointed)
            errors.shown.append(
                f"line {split.line}, columns {self._header[a]} and {self._header[b]}: {whole}"
                f" and {fraction} look like one number written with a decimal comma"
                f" ({whole},{fraction}); {_FIX}"
            )
        return errors
