"""One fusion filter per train, kept as a JSON snapshot so any API worker can continue it."""

from __future__ import annotations

from typing import Any

from sqlalchemy import select
from sqlalchemy.dialects import postgresql, sqlite
from sqlalchemy.orm import Session

from core.database import utcnow
from core.errors import Conflict, NotFound, Unprocessable
from core.models import Section
from core.settings import get_settings
from motion.fusion import FilterConfig, Marker, MarkerTable, StaleSampleError, TrackFilter
from service.trains.models import TrackMarker, TrainPosition
from service.trains.schemas import MarkerIn


def marker_table(session: Session) -> MarkerTable:
    """The line's markers; a section spans the track coordinates of its own markers."""
    markers = session.scalars(select(TrackMarker).order_by(TrackMarker.track_m)).all()
    spans: dict[str, list[float]] = {}
    for marker in markers:
        if marker.section:
            spans.setdefault(marker.section, []).append(marker.track_m)
    return MarkerTable(
        [Marker(m.id, m.track_m, m.lat, m.lon) for m in markers],
        sections=[(ident, min(span), max(span)) for ident, span in spans.items()],
    )


def add_marker(session: Session, data: MarkerIn) -> TrackMarker:
    if session.get(TrackMarker, data.id) is not None:
        raise Conflict(f"marker {data.id!r} already exists")
    if data.section is not None and session.get(Section, data.section) is None:
        raise Unprocessable(f"section {data.section!r} does not exist")
    marker = TrackMarker(**data.model_dump())
    session.add(marker)
    session.flush()
    return marker


def feed(session: Session, train: str, sample: dict[str, Any], at: Any) -> dict[str, Any]:
    """Advance the train's filter by one ``motion_sample``; returns the new state."""
    # Create the train's row race-free (two units may start the same train), then lock it.
    module = postgresql if session.get_bind().dialect.name == "postgresql" else sqlite
    session.execute(
        module.insert(TrainPosition)
        .values(train=train, updated_at=at, state={}, filter_state={})
        .on_conflict_do_nothing(index_elements=["train"])
    )
    row = session.scalars(
        select(TrainPosition)
        .where(TrainPosition.train == train)
        .with_for_update()
        .execution_options(populate_existing=True)
    ).one()
    table = marker_table(session)
    if not row.filter_state:
        track_filter = TrackFilter(table, FilterConfig())
    else:
        try:
            track_filter = TrackFilter.from_dict(row.filter_state, table)
        except ValueError:
            # The marker table changed since the filter started: start again from it.
            track_filter = TrackFilter(table, FilterConfig())
    try:
        state = track_filter.update(sample).as_dict()
    except StaleSampleError:
        # Refused, but counted towards an on-board restart (motion.restart): the
        # count must reach the next sample, whichever worker takes it.
        row.filter_state = track_filter.to_dict()
        session.flush()
        raise
    row.updated_at, row.state, row.filter_state = at, state, track_filter.to_dict()
    session.flush()
    return state


def position(session: Session, train: str) -> dict[str, Any]:
    row = session.get(TrainPosition, train)
    if row is None or not row.state:
        raise NotFound(f"no motion samples received for train {train!r}")
    # Stated on every answer (also for states stored before the field existed):
    # a speed whose σ is beyond FilterConfig.lost_speed_sigma is not known.
    known = float(row.state["sigma_speed_mps"]) <= FilterConfig().lost_speed_sigma
    answer = {
        "train": train,
        "updated_at": row.updated_at.isoformat(),
        **row.state,
        "speed_known": known,
    }
    # The state is the train's as of its newest sample: once its on-board unit is silent for
    # longer than any device may be (DEPOT_HEARTBEAT_S, by the server's clock against the
    # sample's time), where the train is now and how fast it goes are not known — a person
    # must look, rather than read an old coordinate with its old, small uncertainty.
    age_s = (utcnow() - row.updated_at).total_seconds()
    stale = age_s > get_settings().heartbeat_s
    answer |= {"age_s": age_s, "stale": stale}
    if stale:
        answer |= {"position_known": False, "speed_known": False, "section": None}
    return answer
