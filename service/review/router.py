"""The review screen (``/review``): server-rendered, updated in place by ``/review/live``,
dispatcher login by token into a server-side session."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any

from fastapi import APIRouter, Form, Query, Request
from fastapi.responses import FileResponse, HTMLResponse, JSONResponse, RedirectResponse, Response
from fastapi.templating import Jinja2Templates
from pydantic import BaseModel

from core.auth import Principal, person_for_token
from core.database import DbSession, utcnow
from core.errors import DepotError
from core.schemas import holds_nul
from core.settings import get_settings
from core.timefmt import clock_time, date_time
from service.clearance import actions
from service.clearance.router import (
    MAX_ROW_ID,
    RunId,
    SnapshotId,
    get_snapshot_image,
    get_snapshot_overlay,
)
from service.clearance.service import ACTION_STATES
from service.reasons import RULE, meaningful
from service.review import sessions
from service.review.service import (
    ACTION_LABELS,
    DECIDERS,
    DONE_WORDS,
    STATE_WORDS,
    Screen,
    aligned_rows,
    build_screen,
    last_decision,
)

COOKIE = "depot_review"
HERE = Path(__file__).parent
STATIC = {"review.js": "text/javascript", "alert.wav": "audio/wav"}
NUL_WORDS = "The reason holds a NUL character (U+0000): type it again. Nothing was recorded."
FRAGMENTS = ("sections", "queue", "stale", "recent", "run", "actions")
templates = Jinja2Templates(directory=str(HERE / "templates"))
templates.env.globals.update(state_words=STATE_WORDS, action_labels=ACTION_LABELS)
templates.env.filters.update(date_time=date_time)
router = APIRouter(tags=["review screen"], include_in_schema=False)


def _who(request: Request, session: DbSession) -> Principal | None:
    """The person logged in on this browser (shared with the fleet page), or None."""
    return sessions.person(session, request.cookies.get(COOKIE), utcnow())


@router.get("/review/login", response_class=HTMLResponse)
def login_form(request: Request) -> Response:
    return templates.TemplateResponse(request, "login.html", {"error": None})


@router.post("/review/login")
def login(request: Request, session: DbSession, token: Annotated[str, Form()]) -> Response:
    person = person_for_token(session, token.strip())
    cookie = sessions.start(session, token.strip(), person, utcnow()) if person else None
    if cookie is None:
        return templates.TemplateResponse(
            request,
            "login.html",
            {"error": "That token is not known. Ask an administrator for a token."},
            status_code=401,
        )
    response = RedirectResponse("/review", status_code=303)
    response.set_cookie(
        COOKIE,
        cookie,
        httponly=True,
        samesite="strict",
        secure=get_settings().environment == "production",
        max_age=sessions.SESSION_HOURS * 3600,
    )
    return response


@router.post("/review/logout")
def logout(request: Request, session: DbSession) -> Response:
    sessions.end(session, request.cookies.get(COOKIE))
    response = RedirectResponse("/review/login", status_code=303)
    response.delete_cookie(COOKIE)
    return response


def _context(screen: Screen, who: Principal) -> dict[str, Any]:
    now = utcnow()
    return {
        "who": who,
        "screen": screen,
        "may_decide": who.role in DECIDERS,
        "consists": aligned_rows(screen.run) if screen.run else [],
        "refresh_s": get_settings().review_refresh_s,
        "heartbeat_s": get_settings().heartbeat_s,
        "updated": clock_time(now),
    }


@router.get("/review", response_class=HTMLResponse)
def review(
    request: Request,
    session: DbSession,
    run: Annotated[str | None, Query(max_length=32)] = None,
) -> Response:
    who = _who(request, session)
    if who is None:
        return RedirectResponse("/review/login", status_code=303)
    # A person types or edits this URL: a wrong run is said on the page, not answered as JSON.
    run_id = int(run) if run and run.isdigit() and 1 <= int(run) <= MAX_ROW_ID else None
    screen = build_screen(session, run_id=run_id, now=utcnow(), role=who.role)
    context = _context(screen, who)
    context["flash"] = sessions.take_flash(session, request.cookies.get(COOKIE))
    if run and (screen.run is None or screen.run["id"] != run_id):
        context["flash"] = (f"There is no run {run!r}; showing the queue instead.", "error")
    return templates.TemplateResponse(request, "review.html", context)


class LiveScreen(BaseModel):
    """One update of the page: its fragments' HTML, the alerts, the title, when it was built."""

    updated: str  # HH:MM:SS ZONE in the dispatcher's zone (core.timefmt.clock_time)
    run: int | None
    title: str
    alerts: list[dict[str, Any]]
    fragments: dict[str, str]


@router.get("/review/live", response_model=LiveScreen)
def live(
    request: Request,
    session: DbSession,
    run: Annotated[int | None, Query(ge=1, le=MAX_ROW_ID)] = None,
) -> Any:
    """The page's parts, re-rendered; the page swaps them in without touching a typed reason."""
    who = _who(request, session)
    if who is None:
        return JSONResponse({"detail": "logged out"}, status_code=401)
    screen = build_screen(session, run_id=run, now=utcnow(), role=who.role)
    context = _context(screen, who)
    module = templates.env.get_template("fragments.html").make_module(context)
    return LiveScreen(
        updated=context["updated"],
        run=screen.run["id"] if screen.run else None,
        title=screen.title,
        alerts=screen.alerts,
        fragments={name: str(getattr(module, name)()) for name in FRAGMENTS},
    )


@router.get("/review/static/{name}")
def static(name: str) -> Response:
    """The page's script and alert sound, shipped with the app (no build step)."""
    if name not in STATIC:
        return Response(status_code=404)
    return FileResponse(
        HERE / "static" / name,
        media_type=STATIC[name],
        headers={"Cache-Control": "no-cache"},
    )


def _refusal(session: DbSession, run_id: int, action: str) -> str | None:
    """Why the screen refuses an action before recording anything, or None."""
    screen = build_screen(session, run_id=run_id, now=utcnow())
    done = last_decision(screen.run)
    held = next(
        (s for s in screen.sections if screen.run and s["id"] == screen.run["section"]), None
    )
    if done and done["action"] == action and held and held["state"] == ACTION_STATES[action]:
        return (
            f"Run {run_id} is already {done['words']} (by {done['actor']} at"
            f" {date_time(done['recorded_at'])}); nothing was recorded."
        )
    return None


def _decide(
    session: DbSession, who: Principal, run_id: int, action: str, reason: str, seen: str
) -> tuple[str, str]:
    if who.role not in DECIDERS:
        return "Only a dispatcher may clear or block a section.", "error"
    if action not in DONE_WORDS or (kept := meaningful(reason)) is None:
        return f"Give {RULE}. Nothing was recorded.", "error"
    if holds_nul(kept):
        return NUL_WORDS, "error"
    refused = _refusal(session, run_id, action)
    if refused:
        return refused, "error"
    try:
        # The page sends the revision of the run it showed (fragments.actions): a run that
        # changed since is refused (an independent trial: a clear sent from a page not yet
        # refreshed freed a section that had gone to ALARM).
        looks = [[seen]] if seen else []
        actions.act(session, run_id, action, kept, who, utcnow(), seen=looks)
    except DepotError as exc:
        return f"Refused: {exc.detail}; nothing was recorded.", "error"
    if action == "sweep":
        return f"Run {run_id}: the section waits for a sweep train (asked by {who.name}).", "ok"
    return f"Run {run_id}: {DONE_WORDS[action]} by {who.name}.", "ok"


class DecisionMessage(BaseModel):
    """The form's answer to the page's script (asked with ``Accept: application/json``): a
    refusal is shown in place, the run re-read and the typed reason kept."""

    ok: bool
    message: str
    next: str  # where the page goes after a decision taken


@router.post("/review/runs/{run_id}/decision")
def decide(
    request: Request,
    session: DbSession,
    run_id: RunId,
    action: Annotated[str, Form()],
    reason: Annotated[str, Form()] = "",
    seen: Annotated[str, Form(max_length=200)] = "",
) -> Response:
    cookie = request.cookies.get(COOKIE)
    who = _who(request, session)
    scripted = "application/json" in request.headers.get("accept", "")
    if who is None:
        if scripted:
            return JSONResponse({"detail": "logged out"}, status_code=401)
        return RedirectResponse("/review/login", status_code=303)
    message, kind = _decide(session, who, run_id, action, reason, seen)
    after = request.url_for("review").include_query_params(run=run_id)
    if scripted and kind == "error":
        answer = DecisionMessage(ok=False, message=message, next=str(after))
        return JSONResponse(answer.model_dump(), status_code=409)
    sessions.flash(session, cookie, message, kind)
    if scripted:
        return JSONResponse(DecisionMessage(ok=True, message=message, next=str(after)).model_dump())
    return RedirectResponse(after, 303)


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
