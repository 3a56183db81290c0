"""Signs that a measurement CSV was written with decimal commas although its rows still have
as many fields as the header has columns.

A decimal comma that adds a field is caught by the field count. It escapes that check when
the number's fraction lands in a cell that would otherwise be empty: ``2,45`` under
``door_close_s,brake_release_s`` reads as door 2 s and brake 45 s, and an exported header
with a trailing separator hides the fraction in a column without a name. Both are wrong
numbers, not wear, so the import is refused with the line and the columns named.
"""

from __future__ import annotations

import re
from collections.abc import Sequence

_WHOLE = re.compile(r"^[+-]?\d+$")  # how the integer part of a split number looks
_DIGITS = re.compile(r"^\d+$")  # how its fraction looks (no sign, no point, no exponent)
_FIX = "write decimals with a point (2.45), and a whole number as 2.0 in a file of decimals"

Rows = Sequence[tuple[int, Sequence[str]]]


def decimal_comma_problems(
    header: Sequence[str], rows: Rows, *, numeric: Sequence[str]
) -> list[str]:
    """Errors naming line and columns where a decimal comma was most likely split.

    Parameters
    ----------
    header : sequence of str
        The header's column names (stripped; an empty name is a column without a name).
    rows : sequence of (line number, fields)
    numeric : sequence of str
        The header's value columns of a wide file, in header order (empty for a long file).
    """
    return [*_unnamed_values(header, rows), *_split_pairs(header, rows, numeric)]


def _unnamed_values(header: Sequence[str], rows: Rows) -> list[str]:
    blank = [i for i, name in enumerate(header) if not name]
    errors = []
    for line, fields in rows:
        held = [i for i in blank if i < len(fields) and fields[i].strip()]
        if held:
            i = held[0]
            errors.append(
                f"line {line}, column {i + 1} (no name in the header): {fields[i].strip()!r}"
                f" — the fraction of a decimal comma? {_FIX}; or name the column"
            )
    return errors


def _fraction_of(whole: str, fraction: str, decimals_beside: bool) -> bool:
    """Whether ``whole`` and ``fraction`` look like one number split at its decimal comma."""
    if not (_WHOLE.match(whole) and _DIGITS.match(fraction)):
        return False
    # "05" is never how a number is written, only how a fraction is; otherwise a file that
    # writes this column's values with a point would not write a whole number beside digits.
    return (len(fraction) > 1 and fraction.startswith("0")) or decimals_beside


def _split_pairs(header: Sequence[str], rows: Rows, numeric: Sequence[str]) -> list[str]:
    where = {name: i for i, name in enumerate(header)}
    positions = [where[name] for name in numeric]
    pairs = [(a, b) for a, b in zip(positions, positions[1:], strict=False) if b == a + 1]
    pointed = {i for i in positions for _, fields in rows if i < len(fields) and "." in fields[i]}
    errors = []
    for line, fields in rows:
        for a, b in pairs:
            if b >= len(fields):
                continue
            whole, fraction = fields[a].strip(), fields[b].strip()
            if _fraction_of(whole, fraction, a in pointed):
                errors.append(
                    f"line {line}, columns {header[a]} and {header[b]}: {whole} and {fraction}"
                    f" look like one number written with a decimal comma ({whole},{fraction});"
                    f" {_FIX}"
                )
                break
    return errors
