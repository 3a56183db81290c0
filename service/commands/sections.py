"""CLI command: ``depot sections [--json]`` — every block section's state, as the dispatcher's
API and the review screen show it (``GET /api/v1/sections``; the same function answers both).

Found missing by the independent trial: no command showed what the service believes about the
line, so a person at a terminal could not see whether a section is free or must be looked at.
Registered into ``depot`` by ``service.cli`` through :func:`register`.
"""

from __future__ import annotations

import argparse
from typing import Any

from sqlalchemy import select

from core.database import get_sessionmaker
from core.models import Section
from core.timefmt import date_time
from service.clearance.responses import SectionOut
from service.clearance.views import section_out

__all__ = ["register"]


def _line(section: SectionOut) -> str:
    # The screen's words: anything but free is in capitals, as the review screen shows it.
    state = section.state if section.state == "free" else section.state.upper()
    since = date_time(section.state_since)  # in DEPOT_TIME_ZONE, as the review screen
    run = section.run
    verdict = "no decision yet" if run is None or run.decision is None else run.decision.verdict
    what = "" if run is None else f"run {run.id} train {run.train} ({run.status}): {verdict}"
    conflicts = f" conflicts {section.conflict_runs}" if section.conflict_runs else ""
    return f"{section.id:12s} {state:8s} {since:26s} {what}{conflicts}".rstrip()


def _sections(args: argparse.Namespace) -> int:
    with get_sessionmaker().begin() as session:
        rows: list[Any] = list(session.scalars(select(Section).order_by(Section.id)))
        answers = [SectionOut.model_validate(section_out(session, s)) for s in rows]
    if args.json:
        for answer in answers:
            print(answer.model_dump_json())
        return 0
    print(f"{'section':12s} {'state':8s} {'since':26s} current run")
    for answer in answers:
        print(_line(answer))
    if not answers:
        print("no sections yet (POST /api/v1/sections, or `depot demo`)")
    return 0


def register(subparsers: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Add ``sections`` to ``depot``'s sub-command parser."""
    p = subparsers.add_parser(
        "sections", help="every block section's state and current run, as the dispatcher sees it"
    )
    p.add_argument("--json", action="store_true", help="one JSON object per section")
    p.set_defaults(func=_sections)
