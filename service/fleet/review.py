"""The fleet ranking page (``/review/fleet``), behind the review screen's login cookie."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Form, Query, Request
from fastapi.responses import HTMLResponse, RedirectResponse, Response

from core.database import DbSession, utcnow
from core.errors import DepotError
from service.fleet import service, views
from service.fleet.chart import cached_chart
from service.reasons import RULE, meaningful
from service.review import sessions
from service.review.router import COOKIE, _who, templates

router = APIRouter(tags=["review screen"], include_in_schema=False)
DECIDERS = ("engineer", "admin")
ACTION_WORDS = {"keep_in_service": "kept in service", "withdraw_now": "withdrawn now"}
ADVICE_WORDS = {
    "plan_withdrawal": "plan withdrawal",
    "inspect": "a person must look",
    "watch": "watch",
    "serviceable": "serviceable",
    "unknown": "not enough history",
    **ACTION_WORDS,
}


PAGE_SIZE = 20  # cars (and charts) per page: a fleet of thousands must not be one page


def _matching(cars: list[dict[str, Any]], car: str, advice: str) -> list[dict[str, Any]]:
    wanted = car.strip().lower()
    return [
        c
        for c in cars
        if (not wanted or wanted in c["car"].lower()) and (not advice or c["decision"] == advice)
    ]


@router.get("/review/fleet", response_class=HTMLResponse)
def fleet_page(
    request: Request,
    session: DbSession,
    car: Annotated[str, Query(max_length=32)] = "",
    advice: Annotated[str, Query(max_length=32)] = "",
    page: Annotated[int, Query(ge=1, le=100_000)] = 1,
) -> Response:
    who = _who(request, session)
    if who is None:
        return RedirectResponse("/review/login", status_code=303)
    fleet = views.fleet_out(session)
    shown = _matching(fleet["cars"], car, advice if advice in ADVICE_WORDS else "")
    pages = max(1, -(-len(shown) // PAGE_SIZE))
    page = min(page, pages)
    context: dict[str, Any] = {
        "who": who,
        "fleet": fleet,
        "shown": shown[(page - 1) * PAGE_SIZE : page * PAGE_SIZE],
        "matching": len(shown),
        "filter": {"car": car, "advice": advice},
        "page": page,
        "pages": pages,
        "flash": sessions.take_flash(session, request.cookies.get(COOKIE)),
        "may_decide": who.role in DECIDERS,
        "advice_words": ADVICE_WORDS,
    }
    return templates.TemplateResponse(request, "fleet.html", context)


@router.get("/review/fleet/cars/{car_id}/forecast.png")
def fleet_chart(request: Request, session: DbSession, car_id: str) -> Response:
    """The car's chart for the page, behind the page's own login cookie."""
    if _who(request, session) is None:
        return Response(status_code=401)
    forecast = views.latest_forecast(session, car_id)
    if forecast is None:
        return Response(status_code=404)
    key = (forecast.id, forecast.car_id, forecast.computed_at.isoformat())
    png = cached_chart(key, views.forecast_out(session, forecast, views.HISTORY.maximum))
    return Response(png, media_type="image/png", headers={"Cache-Control": "private, max-age=60"})


@router.post("/review/fleet/cars/{car_id}/decision")
def fleet_decide(
    request: Request,
    session: DbSession,
    car_id: str,
    action: Annotated[str, Form()],
    reason: Annotated[str, Form()] = "",
) -> Response:
    who = _who(request, session)
    if who is None or who.role not in DECIDERS:
        return RedirectResponse("/review/login", status_code=303)
    if action not in ACTION_WORDS or (kept := meaningful(reason)) is None:
        notice = f"Give {RULE}."
    else:
        try:
            service.record_override(session, car_id, action, kept, who, utcnow())
            notice = f"Car {car_id}: {ACTION_WORDS[action]}."
        except DepotError as exc:
            notice = exc.detail
    sessions.flash(session, request.cookies.get(COOKIE), notice)
    return RedirectResponse(f"{request.url_for('fleet_page')}#car-{car_id}", status_code=303)
