"""JSON request bodies read as strictly as the device protocol's.

FastAPI reads a body with ``json.loads``, which keeps the last of two equal keys: an engineer's
``{"door_close_s": 2.5, "door_close_s": 2.9}`` stored 2.9 and dropped 2.5 without a word. The
routers of people's APIs use :class:`StrictJSONRoute`, which reads the body first with the
protocol's one JSON reader (:func:`ingest.payload.read_json`: UTF-8, no repeated keys) and
answers 422 before the endpoint runs. The device routes read their bodies themselves with the
same reader.
"""

from __future__ import annotations

from collections.abc import Callable, Coroutine
from typing import Any

from fastapi import Request, Response
from fastapi.routing import APIRoute

from ingest.payload import read_json

_WITH_BODY = frozenset({"POST", "PUT", "PATCH"})


def _is_json(request: Request) -> bool:
    media_type = request.headers.get("content-type", "").split(";")[0].strip().lower()
    return media_type == "application/json" or media_type.endswith("+json")


class StrictJSONRoute(APIRoute):
    """An API route whose JSON body is refused (422) when it repeats a key or is not UTF-8."""

    def get_route_handler(self) -> Callable[[Request], Coroutine[Any, Any, Response]]:
        handler = super().get_route_handler()

        async def checked(request: Request) -> Response:
            if request.method in _WITH_BODY and _is_json(request):
                body = await request.body()  # kept by the request for the endpoint's own read
                if body:
                    read_json(body)
            return await handler(request)

        return checked
