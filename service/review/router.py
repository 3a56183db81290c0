"""The review screen (``/review``): server-rendered, refreshes itself, dispatcher login by token."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

from fastapi import APIRouter, Form, Query, Request
from fastapi.responses import HTMLResponse, RedirectResponse, Response
from fastapi.templating import Jinja2Templates

from core.auth import Principal, person_for_token
from core.database import DbSession, utcnow
from core.errors import DepotError
from core.settings import get_settings
from service.clearance import service as clearance
from service.clearance.router import (
    MAX_ROW_ID,
    RunId,
    SnapshotId,
    get_snapshot_image,
    get_snapshot_overlay,
)
from service.reasons import meaningful
from service.review.service import STATE_WORDS, aligned_rows, build_screen

COOKIE = "depot_review"
templates = Jinja2Templates(directory=str(Path(__file__).parent / "templates"))
templates.env.globals["state_words"] = STATE_WORDS
router = APIRouter(tags=["review screen"], include_in_schema=False)


def _who(request: Request, session: DbSession) -> Principal | None:
    token = request.cookies.get(COOKIE)
    return person_for_token(session, token) if token else None


@router.get("/review/login", response_class=HTMLResponse)
def login_form(request: Request, error: str | None = None) -> Response:
    return templates.TemplateResponse(request, "login.html", {"error": error})


@router.post("/review/login")
def login(request: Request, session: DbSession, token: Annotated[str, Form()]) -> Response:
    person = person_for_token(session, token.strip())
    if person is None:
        return templates.TemplateResponse(
            request,
            "login.html",
            {"error": "That token is not known. Ask an administrator for a token."},
            status_code=401,
        )
    response = RedirectResponse("/review", status_code=303)
    response.set_cookie(
        COOKIE,
        token.strip(),
        httponly=True,
        samesite="strict",
        secure=get_settings().environment == "production",
        max_age=12 * 3600,
    )
    return response


@router.post("/review/logout")
def logout() -> Response:
    response = RedirectResponse("/review/login", status_code=303)
    response.delete_cookie(COOKIE)
    return response


@router.get("/review", response_class=HTMLResponse)
def review(
    request: Request,
    session: DbSession,
    run: Annotated[int | None, Query(ge=1, le=MAX_ROW_ID)] = None,
    notice: str | None = None,
) -> Response:
    who = _who(request, session)
    if who is None:
        return RedirectResponse("/review/login", status_code=303)
    screen = build_screen(session, run_id=run, now=utcnow())
    context: dict[str, Any] = {
        "who": who,
        "screen": screen,
        "notice": notice,
        "consists": aligned_rows(screen.run) if screen.run else [],
        "refresh_s": get_settings().review_refresh_s,
        "heartbeat_s": get_settings().heartbeat_s,
    }
    return templates.TemplateResponse(request, "review.html", context)


DONE_WORDS = {
    "clear": "cleared",
    "keep_blocked": "kept blocked",
    "sweep": "the section waits for a sweep train",
}


@router.post("/review/runs/{run_id}/decision")
def decide(
    request: Request,
    session: DbSession,
    run_id: RunId,
    action: Annotated[str, Form()],
    reason: Annotated[str, Form()] = "",
) -> Response:
    who = _who(request, session)
    if who is None:
        return RedirectResponse("/review/login", status_code=303)
    if who.role not in ("dispatcher", "admin"):
        notice = "Only a dispatcher may clear or block a section."
    elif action not in DONE_WORDS or (kept := meaningful(reason)) is None:
        notice = "Give a reason of at least 3 characters."
    else:
        try:
            clearance.act(session, run_id, action, kept, who, utcnow())
            notice = f"Run {run_id}: {DONE_WORDS[action]}."
        except DepotError as exc:
            notice = exc.detail
    return RedirectResponse(
        request.url_for("review").include_query_params(run=run_id, notice=notice), status_code=303
    )


@router.get("/review/snapshots/{snapshot_id}/{which}")
def snapshot_image(
    request: Request, session: DbSession, snapshot_id: SnapshotId, which: str
) -> Response:
    """Images for the screen, behind the screen's own login cookie."""
    who = _who(request, session)
    if who is None:
        return Response(status_code=401)
    if which == "overlay":
        return get_snapshot_overlay(snapshot_id, session, who)
    return get_snapshot_image(snapshot_id, session, who)  # type: ignore[no-any-return]
