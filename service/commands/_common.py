"""What every CLI command shares: one way to report a problem."""

from __future__ import annotations

import sys


def fail(message: str) -> int:
    """Print ``depot: <message>`` on stderr and return the CLI's exit status for bad input (2).

    The message names the problem and, where there is one, the fix.
    """
    print(f"depot: {message}", file=sys.stderr)
    return 2
