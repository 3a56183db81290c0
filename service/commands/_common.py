"""What every CLI command shares: one way to report a problem, one way to show help."""

from __future__ import annotations

import argparse
import sys
from typing import NoReturn


def fail(message: str) -> int:
    """Print ``depot: <message>`` on stderr and return the CLI's exit status for bad input (2).

    The message names the problem and, where there is one, the fix.
    """
    print(f"depot: {message}", file=sys.stderr)
    return 2


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
        self.print_usage(sys.stderr)
        command = self.prog.removeprefix("depot").strip()
        where = f"{command}: " if command else ""
        self.exit(2, f"depot: {where}{message} (see `{self.prog} --help`)\n")
