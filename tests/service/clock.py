"""The server's clock under the tests' control, to play a night of receive times in seconds.

Liveness is judged by when the server *received* a device's events (protocol.md), so a test
of silence must say when each event reached the server. Every server-side "now" is
``core.database.utcnow``, which reads ``core.database.datetime`` at call time: replacing that
name with a subclass whose ``now`` answers the set instant moves every caller at once.
"""

from __future__ import annotations

from collections.abc import Iterator
from datetime import UTC, datetime, tzinfo
from typing import Any

import pytest

import core.database


class ServerClock:
    """The instant the server believes it is; ``None`` lets the real clock run."""

    def __init__(self) -> None:
        self.at: datetime | None = None

    def set(self, at: datetime) -> None:
        self.at = at.astimezone(UTC)


def _clocked(clock: ServerClock) -> type[datetime]:
    class ClockedDatetime(datetime):
        @classmethod
        def now(cls, tz: tzinfo | None = None) -> Any:
            if clock.at is None:
                return datetime.now(tz)
            return clock.at if tz is None else clock.at.astimezone(tz)

    return ClockedDatetime


@pytest.fixture
def server_clock(monkeypatch: pytest.MonkeyPatch) -> Iterator[ServerClock]:
    clock = ServerClock()
    monkeypatch.setattr(core.database, "datetime", _clocked(clock))
    yield clock
