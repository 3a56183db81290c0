"""What a bridge or consumer did lately, logged every ``every_s`` seconds for operators."""

from __future__ import annotations

import logging
import time
from collections.abc import Callable

LOG_EVERY_S = 5.0


class BatchStats:
    """Messages, batches and the time spent storing them since the last log line (a window
    starts with the first batch after it, so idle time does not dilute the rate)."""

    def __init__(
        self,
        log: logging.Logger,
        *,
        every_s: float = LOG_EVERY_S,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.log, self.every_s, self.clock = log, every_s, clock
        self.since = clock()
        self.messages = self.batches = 0
        self.storing_s = 0.0

    def record(self, messages: int, storing_s: float) -> None:
        """One committed batch of ``messages``, ``storing_s`` seconds from start to commit."""
        now = self.clock()
        if self.batches == 0:  # the window starts with its first batch, not after idle time
            self.since = now - storing_s
        self.messages += messages
        self.batches += 1
        self.storing_s += storing_s
        if now - self.since < self.every_s:
            return
        elapsed = now - self.since
        self.log.info(
            "%d messages in %d batches in %.1f s (%.0f messages/s, mean batch %.0f, "
            "%.0f %% of the time storing)",
            self.messages,
            self.batches,
            elapsed,
            self.messages / elapsed,
            self.messages / self.batches,
            100 * self.storing_s / elapsed,
        )
        self.messages, self.batches, self.storing_s = 0, 0, 0.0
