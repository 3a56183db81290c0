"""The FastAPI application factory."""

from __future__ import annotations

import logging
from typing import Any

from fastapi import FastAPI
from fastapi.openapi.utils import get_openapi
from uvicorn.middleware.proxy_headers import ProxyHeadersMiddleware

from core.errors import install_error_handlers
from core.settings import get_settings
from ingest.envelopes import EventBatch
from ingest.event_log import router as event_log_router
from ingest.router import router as ingest_router
from ingest.schemas import EVENT_ADAPTER, TailSnapshot
from service import features
from service.body_deadline import BodyDeadline
from service.clearance.router import router as clearance_router
from service.docs import install_docs
from service.fleet.review import router as fleet_review_router
from service.fleet.router import router as fleet_router
from service.fleet.schedule import lifespan as fleet_lifespan
from service.health import router as health_router
from service.metrics import router as metrics_router
from service.review.router import router as review_router
from service.setup.credentials_router import router as credentials_router
from service.setup.router import router as setup_router
from service.trains.router import router as trains_router

API = "/api/v1"


def _openapi(app: FastAPI) -> dict[str, Any]:
    """The generated document, plus the event schemas that ``POST /events`` validates by hand."""
    if app.openapi_schema:
        return app.openapi_schema
    schema = get_openapi(
        title=app.title, version=app.version, routes=app.routes, description=app.description
    )
    components = schema.setdefault("components", {}).setdefault("schemas", {})
    ref = "#/components/schemas/{model}"
    event_schema = EVENT_ADAPTER.json_schema(ref_template=ref)
    components.update(event_schema.pop("$defs", {}))
    components["DeviceEvent"] = event_schema
    batch_schema = EventBatch.model_json_schema(ref_template=ref)
    components.update(batch_schema.pop("$defs", {}))
    components["EventBatch"] = batch_schema
    components["Problem"] = PROBLEM_SCHEMA
    components["SnapshotUpload"] = _snapshot_upload_schema()
    _document_snapshot_upload(schema["paths"].get(f"{API}/snapshots", {}).get("post"))
    for path, operations in schema["paths"].items():
        if path.startswith(API):
            for operation in operations.values():
                _document_problems(operation)
    app.openapi_schema = schema
    return schema


PROBLEM_SCHEMA: dict[str, Any] = {
    "type": "object",
    "required": ["type", "title", "status", "detail"],
    "properties": {
        "type": {"type": "string"},
        "title": {"type": "string"},
        "status": {"type": "integer"},
        "detail": {"type": "string"},
        "errors": {
            "type": "array",
            "items": {
                "type": "object",
                "properties": {"loc": {"type": "array"}, "msg": {"type": "string"}},
            },
        },
    },
}
PROBLEMS = {
    "401": "missing or unknown credentials",
    "403": "the role or device kind may not do this",
    "404": "not found",
    "408": "the request body did not arrive within DEPOT_BODY_TIMEOUT_S",
    "409": "conflict with the stored state",
    "413": "too large",
    "415": "unsupported media type",
    "422": "invalid request",
    "503": "the database is unreachable; retry after Retry-After seconds",
}


def _snapshot_upload_schema() -> dict[str, Any]:
    """The multipart form of ``POST /snapshots``: the file ``image`` and the event's fields.

    The route reads the form by hand (to bound its size before parsing), so FastAPI cannot
    see it; the field rules come from the stored event's model, so they cannot drift.
    """
    fields = TailSnapshot.model_json_schema()["properties"]
    return {
        "type": "object",
        "required": ["image", "event_id", "occurred_at", "section"],
        "properties": {
            "image": {
                "type": "string",
                "format": "binary",
                "description": "JPEG or PNG, at most DEPOT_MAX_IMAGE_BYTES and "
                "DEPOT_MAX_IMAGE_PIXELS",
            },
            **{name: fields[name] for name in ("event_id", "occurred_at", "section")},
        },
    }


def _document_snapshot_upload(operation: dict[str, Any] | None) -> None:
    if operation is None:
        return
    schema = {"$ref": "#/components/schemas/SnapshotUpload"}
    operation["requestBody"] = {
        "required": True,
        "content": {
            "multipart/form-data": {
                "schema": schema,
                "encoding": {"image": {"contentType": "image/jpeg, image/png"}},
            }
        },
    }


def _document_problems(operation: dict[str, Any]) -> None:
    """Every error is ``application/problem+json``; say so for each operation."""
    content = {"application/problem+json": {"schema": {"$ref": "#/components/schemas/Problem"}}}
    responses = operation.setdefault("responses", {})
    for status, description in PROBLEMS.items():
        responses[status] = {"description": description, "content": content}


def create_app() -> FastAPI:
    settings = get_settings()
    settings.data_dir.mkdir(parents=True, exist_ok=True)
    logging.basicConfig(
        level=logging.INFO, format="%(asctime)s %(levelname)s %(name)s: %(message)s"
    )
    features.install()
    app = FastAPI(
        title="depot",
        version="0.1.0",
        description="Railway depot and operations service: station devices, block clearance, "
        "car identification, predictive maintenance, motion.",
        lifespan=fleet_lifespan,
        docs_url=None,  # service/docs.py serves both pages without internet
        redoc_url=None,
    )
    install_docs(app)
    if settings.trusted_proxy_list:
        # The one place proxy headers are read (`depot serve` turns uvicorn's own off).
        app.add_middleware(ProxyHeadersMiddleware, trusted_hosts=settings.trusted_proxy_list)
    app.add_middleware(BodyDeadline, seconds=settings.body_timeout_s)
    install_error_handlers(app)
    app.include_router(health_router)
    app.include_router(metrics_router)
    app.include_router(setup_router, prefix=API)
    app.include_router(credentials_router, prefix=API)
    app.include_router(ingest_router, prefix=API)
    app.include_router(event_log_router, prefix=API)
    app.include_router(clearance_router, prefix=API)
    app.include_router(review_router)
    app.include_router(fleet_router, prefix=API)
    app.include_router(fleet_review_router)
    app.include_router(trains_router, prefix=API)
    app.openapi = lambda: _openapi(app)  # type: ignore[method-assign]
    return app
