"""Device protocol endpoints: ``POST /events`` (single or batch) and ``POST /snapshots``."""

from __future__ import annotations

import time
from collections.abc import Awaitable, Callable
from typing import Any, TypeVar

from fastapi import APIRouter, Request
from fastapi.concurrency import run_in_threadpool
from fastapi.responses import JSONResponse, Response
from pydantic import TypeAdapter
from sqlalchemy.orm import Session
from starlette.datastructures import UploadFile
from starlette.requests import ClientDisconnect
from starlette.types import Message

from core import metrics
from core.auth import CurrentDevicePrincipal, Principal
from core.database import DbSession
from core.errors import (
    DepotError,
    PayloadTooLarge,
    Unprocessable,
    UnsupportedMediaType,
)
from core.models import Device
from core.settings import get_settings
from ingest import service
from ingest.batches import batch_events
from ingest.commit_queue import committer_for
from ingest.device_auth import EVENT_SECURITY, EventDevice
from ingest.envelopes import BatchResult, EventAck
from ingest.handlers import prepare
from ingest.payload import read_json
from ingest.snapshots import check_form_fields, check_image, store_image

router = APIRouter(tags=["devices"])
T = TypeVar("T")

EVENT_BODY_DOC = {
    "security": EVENT_SECURITY,
    "requestBody": {
        "required": True,
        "content": {
            "application/json": {
                "schema": {
                    "oneOf": [
                        {"$ref": "#/components/schemas/DeviceEvent"},
                        {"$ref": "#/components/schemas/EventBatch"},
                    ]
                }
            }
        },
    },
}


def bounded(request: Request, limit: int) -> Request:
    """``request`` with its body cut off at ``limit`` bytes: reading past them raises
    :class:`PayloadTooLarge`. A declared length is refused before the form is parsed; a
    chunked upload declares none, and the multipart parser spooled a 1 GB stream to a
    temporary file before the image's own limit refused it (an independent trial)."""
    received = 0
    receive = request.receive

    async def counted() -> Message:
        nonlocal received
        message = await receive()
        if message["type"] == "http.request":
            received += len(message.get("body", b""))
            if received > limit:
                raise PayloadTooLarge(f"the upload exceeds the limit of {limit} bytes")
        return message

    return Request(request.scope, counted)


async def _read_limited(request: Request, limit: int) -> bytes:
    declared = request.headers.get("content-length")
    if declared is not None and declared.isdigit() and int(declared) > limit:
        raise PayloadTooLarge(f"the body has {declared} bytes; the limit is {limit}")
    chunks: list[bytes] = []
    size = 0
    try:
        async for chunk in request.stream():
            size += len(chunk)
            if size > limit:
                raise PayloadTooLarge(f"the body exceeds the limit of {limit} bytes")
            chunks.append(chunk)
    except ClientDisconnect:
        raise _gone() from None
    return b"".join(chunks)


def _gone() -> DepotError:
    # Nothing was stored; the device sends the event again. A refusal rather than the ASGI
    # traceback the server logged for every such request, events and snapshots alike (two
    # independent trials).
    return DepotError("the client closed the connection before its body arrived")


def _committed(store: Callable[..., T], session: Session, *args: Any) -> T:
    """``store(session, *args)`` and the commit, in one worker thread. Committing here rather
    than when the request's session is closed (after the answer is rendered, back on the
    event loop) releases the rows it locked (the section, the device's liveness row) at
    once instead of after the event loop's other work: concurrent events of one section or
    device wait for those locks. The answer is still sent only after the commit."""
    result = store(session, *args)
    session.commit()
    return result


# The batch answer's JSON, written by pydantic's serializer: 500 items in a fraction of what
# ``json.dumps`` takes, and in the worker thread rather than on the event loop.
_BATCH_ANSWER: TypeAdapter[dict[str, list[dict[str, Any]]]] = TypeAdapter(
    dict[str, list[dict[str, Any]]]
)


def _batch_answer(session: Session, device: Device, events: list[Any]) -> bytes:
    """Store a batch and commit; its answer ``{"results": [...]}`` as JSON, counted."""
    results = _committed(service.accept_batch, session, device, events)
    metrics.batch_answered(events, results)
    return _BATCH_ANSWER.dump_json({"results": results})


@router.post(
    "/events",
    openapi_extra=EVENT_BODY_DOC,
    responses={
        201: {"model": EventAck, "description": "a new event, stored and committed"},
        200: {
            "model": EventAck | BatchResult,
            "description": "a retry of a stored event (original result), or batch results",
        },
        409: {"description": "event_id reused with a different body"},
        422: {"description": "invalid event"},
    },
)
async def post_events(request: Request, session: DbSession, device: EventDevice) -> Response:
    """Accept one event, or ``{"events": [...]}`` with at most 1000 events (each stands alone)."""
    started = time.perf_counter()  # metrics: decision latency
    settings = get_settings()
    content_type = request.headers.get("content-type", "")
    if not content_type.split(";")[0].strip().lower().endswith("json"):
        raise UnsupportedMediaType("send events as application/json")
    body = await _read_limited(request, settings.max_body_bytes)
    payload = read_json(body)
    events = batch_events(payload)
    if events is not None:
        answer = await run_in_threadpool(_batch_answer, session, device, events)
        return Response(answer, status_code=200, media_type="application/json")
    single = _single(session, device, payload, large=len(body) > INLINE_BYTES)
    status, result = await _counted(payload, started, single)
    return JSONResponse(result, status_code=status)


async def _counted(
    payload: Any, started: float, answering: Awaitable[tuple[int, dict[str, Any]]]
) -> tuple[int, dict[str, Any]]:
    """``answering``'s answer, counted in the metrics (a refusal by its status, re-raised);
    ``started`` is when the request came in."""
    try:
        status, result = await answering
    except DepotError as exc:
        metrics.event_answered(payload, exc.status, started)
        raise
    metrics.event_answered(payload, status, started)
    return status, result


# Bodies up to this size are validated on the event loop (microseconds); larger ones (long
# pulse or sample lists) in a thread, so that they never hold up other requests.
INLINE_BYTES = 16 * 1024


async def _single(
    session: Session, device: Device, payload: Any, *, large: bool
) -> tuple[int, dict[str, Any]]:
    """One event: through the worker's group commit when it is on, else in its own
    transaction (the request session's, committed before the answer is sent)."""
    settings = get_settings()
    committer = committer_for(
        session,
        service.store_group,
        service.store_validated,
        window_ms=settings.group_commit_ms,
        max_events=settings.group_commit_max,
    )
    if committer is None:
        return await run_in_threadpool(_committed, service.accept_event, session, device, payload)
    if large:
        event = await run_in_threadpool(service.validate_event, device, payload)
    else:
        event = service.validate_event(device, payload)
    if session.in_transaction():
        # The key look-up (cold cache, e.g. after a restart) holds a pooled connection; given
        # back before waiting, else waiting requests can take every connection from the group.
        await run_in_threadpool(session.close)
    result: tuple[int, dict[str, Any]] = await committer.submit(device, event, payload)
    return result


@router.post(
    "/snapshots",
    responses={
        201: {"model": EventAck, "description": "stored"},
        200: {"model": EventAck, "description": "a retry (original result)"},
        413: {},
        422: {},
    },
)
async def post_snapshot(
    request: Request, session: DbSession, principal: CurrentDevicePrincipal
) -> JSONResponse:
    """Multipart upload of a tail-car image with ``event_id``, ``occurred_at`` and ``section``."""
    kind = {"kind": "tail_snapshot"}  # counted like every device event, refusals too
    snapshot = _snapshot(request, session, principal)
    status, result = await _counted(kind, time.perf_counter(), snapshot)
    return JSONResponse(result, status_code=status)


async def _snapshot_form(
    request: Request, limit: int, max_image_bytes: int
) -> tuple[bytes, dict[str, Any]]:
    """The image's bytes (at most one past its limit) and the event's form fields."""
    try:
        async with bounded(request, limit).form(max_files=1, max_fields=10) as form:
            check_form_fields(name for name, _ in form.multi_items())
            upload = form.get("image")
            if not isinstance(upload, UploadFile):
                raise Unprocessable(
                    "the 'image' file is missing",
                    errors=[{"loc": ["body", "image"], "msg": "field required"}],
                )
            data = await upload.read(max_image_bytes + 1)
            return data, {k: form.get(k) for k in ("event_id", "occurred_at", "section")}
    except ClientDisconnect:
        raise _gone() from None


async def _snapshot(
    request: Request, session: Session, principal: Principal
) -> tuple[int, dict[str, Any]]:
    settings = get_settings()
    if not request.headers.get("content-type", "").startswith("multipart/form-data"):
        raise UnsupportedMediaType("send snapshots as multipart/form-data with an 'image' file")
    declared = request.headers.get("content-length", "")
    limit = settings.max_image_bytes + 64 * 1024  # the image and its form fields
    if declared.isdigit() and int(declared) > limit:
        raise PayloadTooLarge(
            f"the upload has {declared} bytes; the image limit is {settings.max_image_bytes}"
        )
    data, fields = await _snapshot_form(request, limit, settings.max_image_bytes)
    missing = [k for k, v in fields.items() if not isinstance(v, str) or not v]
    if missing:
        raise Unprocessable(
            f"missing form fields: {', '.join(missing)}",
            errors=[{"loc": ["body", k], "msg": "field required"} for k in missing],
        )
    checked = await run_in_threadpool(
        check_image, data, max_bytes=settings.max_image_bytes, max_pixels=settings.max_image_pixels
    )
    payload = {
        "kind": "tail_snapshot",
        **fields,
        "image_sha256": checked.sha256,
        "content_type": checked.content_type,
        "width": checked.width,
        "height": checked.height,
        "size_bytes": len(data),
    }
    device = principal.device
    assert device is not None
    event = await run_in_threadpool(service.validate_snapshot, session, device, payload)
    known = await run_in_threadpool(service.answer_if_stored, session, device, event, payload)
    if known is not None:  # a retry, answered without writing its image again
        return known
    # The file goes to disk before the event: a stored event never points at a missing image.
    await run_in_threadpool(store_image, settings.image_dir, checked, data)
    if session.in_transaction():
        await run_in_threadpool(session.commit)  # nothing written yet; no connection held
    # Detection runs here, in a thread and outside the transaction: the derivation, which
    # holds the section's lock, then finds the verdict ready instead of computing it.
    await run_in_threadpool(prepare, device, event)
    answer: tuple[int, dict[str, Any]] = await run_in_threadpool(
        _committed, service.store_event, session, device, event, payload
    )
    return answer
