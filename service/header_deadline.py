"""A connection must send a request's headers in time, or it is closed.

uvicorn times out only a kept-alive connection that sends nothing: a connection that
opens and never finishes its headers (slowloris), or sends nothing at all, is held for
ever, and an independent trial held 20,000 of them until the server could accept no one
(``/healthz`` unanswered). :class:`HeaderDeadlineProtocol` closes a connection that has not
completed a request's headers within ``DEPOT_HEADER_TIMEOUT_S`` of opening or of its
previous answer. A request whose headers arrived is never cut by this: its body has its
own deadline (:mod:`service.body_deadline`) and its answer takes what it takes.

It extends uvicorn's httptools protocol (the one uvicorn itself picks where httptools is
installed, as ``uvicorn[standard]`` does), passed as ``http=`` to :func:`uvicorn.run`.
"""

from __future__ import annotations

import asyncio
from typing import Any

from uvicorn.protocols.http.httptools_impl import HttpToolsProtocol

from core.settings import get_settings

__all__ = ["HeaderDeadlineProtocol"]


class HeaderDeadlineProtocol(HttpToolsProtocol):
    """uvicorn's httptools protocol with the header deadline: a timer is armed when the
    connection opens and after each answer; when it fires and no request has begun since
    (the same cycle, finished, or none yet), the connection is closed."""

    _headers_timer: asyncio.TimerHandle | None = None

    def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore[override]
        super().connection_made(transport)
        self._arm_header_deadline()

    def on_response_complete(self) -> None:
        super().on_response_complete()
        self._arm_header_deadline()

    def connection_lost(self, exc: Exception | None) -> None:
        self._disarm_header_deadline()
        super().connection_lost(exc)

    def _arm_header_deadline(self) -> None:
        self._disarm_header_deadline()
        if self.transport.is_closing():
            return
        seconds = get_settings().header_timeout_s
        self._headers_timer = self.loop.call_later(seconds, self._headers_late, self.cycle)

    def _disarm_header_deadline(self) -> None:
        if self._headers_timer is not None:
            self._headers_timer.cancel()
            self._headers_timer = None

    def _headers_late(self, armed: Any) -> None:
        self._headers_timer = None
        idle = self.cycle is armed and (armed is None or armed.response_complete)
        if idle and not self.transport.is_closing():
            self.transport.close()
