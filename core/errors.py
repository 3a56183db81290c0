"""One error base class, mapped to one ``application/problem+json`` handler."""

from __future__ import annotations

import logging
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from sqlalchemy.exc import DataError, InterfaceError, OperationalError, PendingRollbackError
from sqlalchemy.exc import TimeoutError as PoolTimeout
from starlette.exceptions import HTTPException as StarletteHTTPException

PROBLEM_JSON = "application/problem+json"
log = logging.getLogger("depot")


class DepotError(Exception):
    """Base of every error the service reports to a client."""

    status: int = 400
    title: str = "Bad request"
    headers: dict[str, str] | None = None

    def __init__(self, detail: str, *, errors: list[dict[str, Any]] | None = None) -> None:
        super().__init__(detail)
        self.detail = detail
        self.errors = errors


class Unauthorized(DepotError):
    status, title = 401, "Unauthorized"
    headers = {"WWW-Authenticate": "Bearer"}


class Forbidden(DepotError):
    status, title = 403, "Forbidden"


class NotFound(DepotError):
    status, title = 404, "Not found"


class RequestTimeout(DepotError):
    # The connection cannot carry another request: its body was never read to the end.
    status, title = 408, "Request timeout"
    headers = {"Connection": "close"}


class Conflict(DepotError):
    status, title = 409, "Conflict"


class PayloadTooLarge(DepotError):
    status, title = 413, "Payload too large"


class UnsupportedMediaType(DepotError):
    status, title = 415, "Unsupported media type"


class Unprocessable(DepotError):
    status, title = 422, "Unprocessable content"


class ServiceUnavailable(DepotError):
    status, title = 503, "Service unavailable"
    headers = {"Retry-After": "5"}


def problem(
    status: int,
    title: str,
    detail: str,
    *,
    errors: list[dict[str, Any]] | None = None,
    headers: dict[str, str] | None = None,
) -> JSONResponse:
    body: dict[str, Any] = {
        "type": "about:blank",
        "title": title,
        "status": status,
        "detail": detail,
    }
    if errors is not None:
        body["errors"] = errors
    return JSONResponse(body, status_code=status, media_type=PROBLEM_JSON, headers=headers)


def validation_errors(raw: list[Any]) -> list[dict[str, Any]]:
    """Reduce pydantic's error list to ``{"loc", "msg"}`` items, safe to serialise."""
    return [{"loc": [str(p) for p in e.get("loc", ())], "msg": str(e.get("msg", ""))} for e in raw]


def install_error_handlers(app: FastAPI) -> None:
    @app.exception_handler(DepotError)
    async def _depot(_: Request, exc: DepotError) -> JSONResponse:
        return problem(exc.status, exc.title, exc.detail, errors=exc.errors, headers=exc.headers)

    @app.exception_handler(RequestValidationError)
    async def _validation(_: Request, exc: RequestValidationError) -> JSONResponse:
        errors = validation_errors(list(exc.errors()))
        fields = ", ".join(".".join(e["loc"]) for e in errors[:5])
        return problem(422, "Unprocessable content", f"invalid request: {fields}", errors=errors)

    @app.exception_handler(StarletteHTTPException)
    async def _http(_: Request, exc: StarletteHTTPException) -> JSONResponse:
        return problem(
            exc.status_code, str(exc.detail), str(exc.detail), headers=dict(exc.headers or {})
        )

    async def _database_down(_: Request, exc: Exception) -> JSONResponse:
        log.warning("database unavailable: %s", type(exc).__name__)
        return problem(
            503,
            "Service unavailable",
            "the database is unreachable; retry later",
            headers={"Retry-After": "5"},
        )

    # PoolTimeout: every connection of the worker's pool is busy; as good as unreachable.
    for failure in (OperationalError, InterfaceError, PendingRollbackError, PoolTimeout):
        app.add_exception_handler(failure, _database_down)

    @app.exception_handler(DataError)
    async def _bad_value(_: Request, exc: DataError) -> JSONResponse:
        # e.g. a NUL character or an out-of-range number in an identifier
        return problem(422, "Unprocessable content", "a value cannot be stored or looked up")
