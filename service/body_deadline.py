"""The request body's deadline: a body that has not arrived in time is refused (408).

uvicorn has no body timeout: a client that sends its headers and then trickles its body
(slowloris), or a device whose link dies mid-upload without a reset, keeps a request
open for ever, and enough of them exhaust the database connections and the memory their
half-read uploads hold. The deadline counts from the request's start and bounds the
whole body, so a byte now and then (which a per-read timeout would let through) does not
extend it. Nothing is stored: the body is refused before any of it is accepted.
"""

from __future__ import annotations

import asyncio

from starlette.types import ASGIApp, Message, Receive, Scope, Send

from core.errors import RequestTimeout

__all__ = ["BodyDeadline"]


class BodyDeadline:
    """ASGI middleware: each HTTP request's body must arrive within ``seconds``.

    Reading past the deadline raises :class:`~core.errors.RequestTimeout` inside the
    endpoint that reads, which answers it as ``application/problem+json``. Once the body is
    complete, later reads (a streaming response listening for the client's disconnect)
    wait as long as they like.
    """

    def __init__(self, app: ASGIApp, *, seconds: float) -> None:
        self.app = app
        self.seconds = seconds

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        loop = asyncio.get_running_loop()
        deadline = loop.time() + self.seconds
        complete = False

        async def timed() -> Message:
            nonlocal complete
            if complete:
                return await receive()
            try:
                async with asyncio.timeout_at(deadline):
                    message = await receive()
            except TimeoutError:
                raise RequestTimeout(
                    f"the request body did not arrive within {self.seconds:g} s "
                    "(DEPOT_BODY_TIMEOUT_S); send it again on a working link"
                ) from None
            complete = message["type"] != "http.request" or not message.get("more_body", False)
            return message

        await self.app(scope, timed, send)
