"""One fusion filter per train, kept as a JSON snapshot so any API worker can continue it."""

from __future__ import annotations

from datetime import datetime
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


# The filter_state document: one snapshot per on-board unit.  A row written before units
# were kept apart holds one bare snapshot (it has "version"): the first unit to report
# after the upgrade continues it.
_DEVICES = "devices"
# What the train's answer shows of each unit's own estimate.
_UNIT_KEYS = (
    "t",
    "position_m",
    "speed_mps",
    "direction",
    "sigma_position_m",
    "sigma_speed_mps",
    "position_known",
    "section",
)


def _unit_snapshots(filter_state: dict[str, Any], device: str) -> dict[str, Any]:
    if not filter_state:
        return {}
    if _DEVICES not in filter_state:
        return {device: filter_state}
    units: dict[str, Any] = filter_state[_DEVICES]
    return units


def _unit_filter(table: MarkerTable, snapshot: dict[str, Any] | None) -> TrackFilter:
    if not snapshot:
        return TrackFilter(table, FilterConfig())
    try:
        return TrackFilter.from_dict(snapshot, table)
    except ValueError:
        # The marker table changed since the filter started: start again from it.
        return TrackFilter(table, FilterConfig())


def _locked_row(session: Session, train: str, at: Any) -> TrainPosition:
    """The train's row, created race-free (two units may start the same train), locked."""
    module = postgresql if session.get_bind().dialect.name == "postgresql" else sqlite
    session.execute(
        module.insert(TrainPosition)
        .values(train=train, updated_at=at, state={}, filter_state={})
        .on_conflict_do_nothing(index_elements=["train"])
    )
    return session.scalars(
        select(TrainPosition)
        .where(TrainPosition.train == train)
        .with_for_update()
        .execution_options(populate_existing=True)
    ).one()


def feed(
    session: Session, train: str, sample: dict[str, Any], at: Any, device: str = ""
) -> dict[str, Any]:
    """Advance the filter of the train's unit ``device`` by one ``motion_sample``; returns
    the unit's new state.

    Every on-board unit of a train has its own filter: two units (one in each cab, a
    replacement fitted) run their own clocks, and one filter fed both took each unit's
    samples as a clock jump or a restart of the other and wiped the train's estimate
    (found by the independent trial).  The train's state is that of the unit that
    reported last, with every unit's own estimate under ``devices``.
    """
    row = _locked_row(session, train, at)
    units = dict(_unit_snapshots(row.filter_state, device))
    track_filter = _unit_filter(marker_table(session), units.get(device))
    try:
        state = track_filter.update(sample).as_dict()
    except StaleSampleError:
        # Refused, but counted towards an on-board restart or a clock jump (motion.restart):
        # the count must reach the next sample, whichever worker takes it.
        units[device] = track_filter.to_dict()
        row.filter_state = {_DEVICES: units}
        session.flush()
        raise
    units[device] = track_filter.to_dict()
    seen = {u["device"]: u for u in row.state.get(_DEVICES, [])}
    seen[device] = {
        "device": device,
        "updated_at": at.isoformat(),
        **{k: state.get(k) for k in _UNIT_KEYS},
    }
    row.updated_at, row.filter_state = at, {_DEVICES: units}
    row.state = {**state, "device": device, _DEVICES: [seen[k] for k in sorted(seen)]}
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
        # (states stored before these fields existed: no unit named, GNSS not disagreeing)
        "device": None,
        "devices": [],
        "gnss_disagrees": False,
        **row.state,
        "speed_known": known,
    }
    # The state is the train's as of its newest sample: once its on-board unit is silent for
    # longer than any device may be (DEPOT_HEARTBEAT_S, by the server's clock against the
    # sample's time), where the train is now and how fast it goes are not known — a person
    # must look, rather than read an old coordinate with its old, small uncertainty.
    now, heartbeat_s = utcnow(), get_settings().heartbeat_s
    age_s = (now - row.updated_at).total_seconds()
    stale = age_s > heartbeat_s
    answer |= {"age_s": age_s, "stale": stale}
    units = []
    for unit in answer["devices"]:
        unit_age = (now - datetime.fromisoformat(unit["updated_at"])).total_seconds()
        unit_stale = unit_age > heartbeat_s
        units.append(
            unit | {"stale": unit_stale} | ({"position_known": False} if unit_stale else {})
        )
    answer["devices"] = units
    if stale:
        answer |= {"position_known": False, "speed_known": False, "section": None}
    return answer
