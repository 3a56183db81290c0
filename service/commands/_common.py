"""What every CLI command shares: one way to report a problem, one way to show help."""

from __future__ import annotations

import argparse
import math
import os
import re
import sys
from collections.abc import Callable
from pathlib import Path
from typing import NoReturn


def fail(message: str) -> int:
    """Print ``depot: <message>`` on stderr and return the CLI's exit status for bad input (2).

    The message names the problem and, where there is one, the fix.
    """
    print(f"depot: {message}", file=sys.stderr)
    return 2


def writable(out: Path, option: str, example: str) -> str | None:
    """Why ``out`` (given as ``option``) cannot be written, with the fix, or None: checked
    before the work, so a mistyped ``--out`` does not cost a calibration or a training and
    then a traceback. ``example`` is a file name to suggest when ``out`` is a folder."""
    if out.is_dir():
        return f"{option} {out} is a folder; give a file name, e.g. {option} {out / example}"
    parent = out.parent
    if not parent.exists():
        return f"folder {parent} does not exist; create it or choose another {option}"
    if not parent.is_dir():
        return f"{parent} is not a folder; choose another {option}"
    if not os.access(parent, os.W_OK):
        return f"folder {parent} is not writable; choose another {option}"
    return None


def values_may_look_negative(
    parser: argparse.ArgumentParser, value: re.Pattern[str]
) -> argparse.ArgumentParser:
    """Let ``parser`` take arguments matching ``value`` (e.g. ``-1e6``, ``-1,10``) as values.

    argparse takes anything starting with "-" and a digit for an option unless the parser
    has an option that looks like a number, and says "expected one argument"; for parsers
    with no such option a value of that form is a value (then refused, if it must be, by
    its own check). ``--option=-1`` works with any parser.
    """
    parser._negative_number_matcher = value  # argparse's own (private) hook for this
    return parser


def write_file(out: Path, text: str, option: str) -> str | None:
    """Write ``text`` to ``out``; why it failed (with the fix), or None."""
    try:
        out.write_text(text, encoding="utf-8")
    except OSError as exc:
        return f"cannot write {out}: {exc.strerror or exc}; choose another {option}"
    return None


class DepotHelpFormatter(argparse.HelpFormatter):
    """Every option's help ends with its default, unless the text already says it."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        flag = action.nargs == 0  # store_true and friends: off unless given
        if (
            action.option_strings
            and not flag
            and not action.required
            and action.default not in (None, argparse.SUPPRESS)
            and "default" not in text
        ):
            text += " (default: %(default)s)"
        return text


class DepotParser(argparse.ArgumentParser):
    """``argparse`` with depot's help format and its one error prefix ``depot:``.

    Sub-command parsers are made of the same class (argparse uses the parent's type).
    """

    def __init__(self, *args: object, **kwargs: object) -> None:
        kwargs.setdefault("formatter_class", DepotHelpFormatter)
        super().__init__(*args, **kwargs)  # type: ignore[arg-type]

    def error(self, message: str) -> NoReturn:
        # One line, as every other refusal: the usage is one `--help` away, and it named
        # nothing the message does not.
        command = self.prog.removeprefix("depot").strip()
        where = f"{command}: " if command else ""
        self.exit(2, f"depot: {where}{message} (see `{self.prog} --help`)\n")


def number(
    kind: type[float] | type[int] = float,
    *,
    low: float | None = None,
    high: float | None = None,
    low_open: bool = False,
    high_open: bool = False,
) -> Callable[[str], float]:
    """An argparse ``type`` for a finite number in a range: NaN, ±inf and values outside
    [low, high] (open where asked) are refused with a ``depot:`` message saying the range.

    Every numeric option of the CLI goes through it, so 0, -1, nan or inf never reach a
    division or an allocation (found by the independent trial: --pixel-fov 0 divided by zero).
    """

    def shown(bound: float) -> str:
        # a whole-number bound in full: 2**32 - 1 is 4294967295, not 4.29497e+09
        return str(int(bound)) if kind is int and float(bound).is_integer() else f"{bound:g}"

    words = []
    if low is not None:
        words.append(f"{'more than' if low_open else 'at least'} {shown(low)}")
    if high is not None:
        words.append(f"{'less than' if high_open else 'at most'} {shown(high)}")
    noun = "a whole number" if kind is int else "a number"
    wanted = noun + (" " + " and ".join(words) if words else "")

    def convert(text: str) -> float:
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not {wanted}") from None
        if not math.isfinite(value):
            raise argparse.ArgumentTypeError(f"{text!r} is not {wanted}")
        if low is not None and (value < low or (low_open and value == low)):
            raise argparse.ArgumentTypeError(f"{text!r} is not {wanted}")
        if high is not None and (value > high or (high_open and value == high)):
            raise argparse.ArgumentTypeError(f"{text!r} is not {wanted}")
        return value

    convert.__name__ = noun  # argparse names the type in some messages
    return convert


POSITIVE = number(low=0, low_open=True)  # lengths, times, speeds, angles
NON_NEGATIVE = number(low=0)
FINITE = number()  # a coordinate or a gradient: any sign
PROBABILITY = number(low=0, high=1, low_open=True, high_open=True)
SEED = number(int, low=0, high=2**32 - 1)  # numpy's seeds
COUNT = number(int, low=1)
