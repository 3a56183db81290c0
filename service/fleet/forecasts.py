"""The fleet forecast job: read every car's stored history in bulk, assess it, append forecasts.

Reading, computing and writing overlap on PostgreSQL (:mod:`service.fleet.pipeline`).
One streamed read of the tests ordered by car (never one query per car, see
:mod:`service.fleet.history`): the first cars calibrate the fleet's weights and index band (see
:mod:`service.fleet.calibration`), then chunks of cars are assessed — vectorised over cars
sharing the fleet weights and history length (:mod:`service.fleet.vectorised`), per car
otherwise — and written with multi-row inserts. Every registered car gets a
forecast row, so cars without enough history show in the fleet view too (last, with the reason).
"""

from __future__ import annotations

import contextlib
import itertools
import json
import logging
import math
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from datetime import datetime, timedelta
from functools import partial
from typing import Any

import numpy as np
import orjson
from sqlalchemy import Engine, insert, select
from sqlalchemy.orm import Session

from core.database import utcnow
from core.errors import Unprocessable
from core.models import Car
from maintenance.fleet import CarAssessment, assess_car
from service.fleet.calibration import SAMPLE_CARS, FleetIndex, calibrate
from service.fleet.history import Bands, CarHistory, empty_history, histories, load_bands
from service.fleet.models import Forecast
from service.fleet.pipeline import Writer, read_ahead
from service.fleet.vectorised import Outcome, batch_assessments, payload_of
from service.fleet.verdict import judge, rank_key

log = logging.getLogger("depot.fleet")
Progress = Callable[[int, int], None]
_WRITE_CHUNK = 500
TOP_CARS = 5  # cars a run names as its highest risk (the fleet view lists them all)
_COMPUTE_CHUNK = 1000  # cars assessed together (vectorised per history length)
_READ_AHEAD = 2 * _COMPUTE_CHUNK  # car histories the reader may hold ahead of the computation
NO_HISTORY = "no measurements of parameters with a tolerance band"
TOO_SPARSE = "no parameter with a tolerance band was measured at half of the car's tests or more"


@dataclass(frozen=True)
class ForecastOptions:
    """How the fleet job forecasts (README "Maintenance forecasts").

    Attributes
    ----------
    method : str
        Weights: ``prediction`` (4.16), ``inverse_variance``, ``rayleigh``, ``equal``, ``fisher``.
    horizon : int
        Tests forecast ahead.
    order : int
        AR order of the index forecast.
    failure_k : int
        K of the spec's K-of-L failure criterion: at least K of the L predictive parameters out
        of tolerance is a failure (``k_of_l_probability``; the calibration's faulty tests);
        with fewer parameters than K, all of them.
    false_alarm : float
        The calibrated index band's type-I probability on serviceable tests.
    """

    method: str = "prediction"
    horizon: int = 30
    order: int = 2
    failure_k: int = 2
    false_alarm: float = 0.01


@dataclass
class FleetRun:
    """What one run of the job wrote."""

    computed_at: datetime
    calibration: str = ""
    cars: int = 0
    statuses: dict[str, int] = field(default_factory=dict)
    top: list[tuple[str, float]] = field(default_factory=list)


def assess(
    history: CarHistory, bands: Bands, fleet: FleetIndex, options: ForecastOptions
) -> tuple[CarAssessment, str]:
    """The car's assessment (``history`` holds at least one parameter) and how it was weighted."""
    common: dict[str, Any] = dict(
        times=history.days, order=options.order, horizon=options.horizon, car_id=history.car_id
    )
    if fleet.calibrated and set(fleet.names) <= set(history.names):
        cols = [history.names.index(n) for n in fleet.names]
        result = assess_car(
            history.values[:, cols], band=bands.of(fleet.names), names=fleet.names,
            weights=fleet.weights, index_band=fleet.index_band,
            k=min(options.failure_k, len(fleet.names)), **common,
        )  # fmt: skip
        return result, fleet.note
    if options.method == "fisher":
        raise ValueError("fisher weights need the fleet calibration, which this car lacks")
    note = fleet.note if not fleet.calibrated else "per-car weights: not every fleet parameter"
    result = assess_car(
        history.values, band=bands.of(history.names), names=history.names,
        weights_method=options.method, k=min(options.failure_k, len(history.names)), **common,
    )  # fmt: skip
    return result, note


def _outcome(
    history: CarHistory, bands: Bands, fleet: FleetIndex, options: ForecastOptions
) -> tuple[str, float | None, dict[str, Any]]:
    if not len(history):
        return "not_enough_history", None, {"reasons": [NO_HISTORY]}
    if not history.names:
        return "not_enough_history", None, {"reasons": [TOO_SPARSE]}
    try:
        result, note = assess(history, bands, fleet, options)
    except (ValueError, np.linalg.LinAlgError, FloatingPointError) as exc:
        # One car's odd history must not stop the fleet run; its row says what went wrong.
        log.warning("forecast of car %s failed: %s", history.car_id, exc)
        return "failed", None, {"reasons": [f"forecast failed: {exc}"]}
    return assessed(result, note)


def assessed(result: CarAssessment, note: str) -> tuple[str, float | None, dict[str, Any]]:
    """Status, risk and payload of an assessment."""
    if result.status != "ok":
        # Built here rather than by to_dict(), which fails on an assessment without arrays.
        return result.status, None, {"reasons": list(result.reasons), "calibration": note,
                                     "n_measurements": result.n_measurements,
                                     "times": result.times.tolist()}  # fmt: skip
    return result.status, result.risk, {**payload_of(result), "calibration": note}


def _finite(value: Any) -> Any:
    """JSON without NaN/inf (PostgreSQL's json type refuses them)."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_finite(v) for v in value]
    return value


def out_of_band_now(payload: dict[str, Any]) -> bool:
    """Whether the car's latest index already lies outside its band."""
    index, band = payload.get("index") or [], payload.get("index_band")
    if not index or not band or index[-1] is None:
        return False
    return not band[0] <= index[-1] <= band[1]


def out_of_tolerance_now(history: CarHistory, bands: Bands) -> list[tuple[str, str]]:
    """The banded parameters outside their tolerance band at the car's latest test, each with
    the words that say so (``door_close_s = 3.2 s, band 1.9…2.9 s``)."""
    if not len(history) or not history.names:
        return []
    latest, limits = history.values[-1], bands.of(history.names)
    # NaN counts as out: no evidence is never "clear"
    outside = ~((limits[:, 0] <= latest) & (latest <= limits[:, 1]))
    out = []
    for j in np.flatnonzero(outside):
        name, value, (lower, upper) = history.names[j], latest[j], limits[j]
        unit = f" {bands.units[name]}" if bands.units.get(name) else ""
        out.append((name, f"{name} = {value:g}{unit}, band {lower:g}…{upper:g}{unit}"))
    return out


def forecast_row(
    history: CarHistory,
    bands: Bands,
    fleet: FleetIndex,
    options: ForecastOptions,
    at: datetime,
    outcome: tuple[str, float | None, dict[str, Any]] | None = None,
) -> dict[str, Any]:
    """The Forecast row (as insert values) of one car (``outcome``: assessed already)."""
    status, risk, payload = outcome or _outcome(history, bands, fleet, options)
    if status == "ok":
        risk = judge(
            payload, history.names, history.values, bands.of(history.names),
            calibrated=fleet.calibrated, horizon=options.horizon, failure_k=options.failure_k,
        )  # fmt: skip
    step = payload.get("first_exit")
    out_now = out_of_tolerance_now(history, bands)
    payload["out_of_tolerance_now"] = [name for name, _ in out_now]
    payload["out_of_band_now"] = out_of_band_now(payload) or bool(out_now)
    if out_now:
        # Whatever the index says (an uncalibrated band may be wide): a person must look.
        listed = "; ".join(words for _, words in out_now)
        payload["reasons"] = [
            f"already outside its band: {listed} (out of tolerance at the latest test)",
            *payload.get("reasons", []),
        ]
    if step is not None and payload.get("forecast") and not payload["out_of_band_now"]:
        # The package words the exit in days since the first test; engineers plan by the date.
        when = history.start + timedelta(days=payload["forecast"]["times"][step - 1])
        ahead = "at the next test" if step == 1 else f"{step} tests ahead"
        payload["reasons"] = [
            f"expected to leave its index band by {when:%Y-%m-%d} ({ahead})",
            *payload.get("reasons", []),
        ]
    kept = list(payload.get("weights") or history.names)
    payload.update(
        status=status,
        car_id=history.car_id,
        method=options.method,
        start=history.start.isoformat() if len(history) else None,
        time_unit="days",
        horizon=options.horizon,
        order=options.order,
        failure_k=options.failure_k,
        **bands.described(kept),
    )
    return {
        "car_id": history.car_id,
        "computed_at": at,
        "status": status,
        "risk": risk if risk is None or math.isfinite(risk) else None,
        "payload": payload,  # made JSON-safe when written (see write_forecasts)
    }


def calibrate_fleet_index(
    sample: list[CarHistory], bands: Bands, options: ForecastOptions
) -> FleetIndex:
    fleet = calibrate(
        sample, bands, method=options.method, order=options.order,
        failure_k=options.failure_k, false_alarm=options.false_alarm,
    )  # fmt: skip
    if options.method == "fisher" and not fleet.calibrated:
        raise Unprocessable(
            f"fisher weights need labelled fleet records: {fleet.note}; use method prediction"
        )
    return fleet


def _reader_session(session: Session) -> Session | None:
    """A session of its own for the reader thread, or None to read through ``session``.

    Only on PostgreSQL with ``session`` bound to an engine: the reader sees committed
    measurements (the job's own uncommitted writes are forecast rows, never read).
    A session bound to one connection (an outer transaction, as in tests) reads
    through that connection, in the job's thread.
    """
    bind = session.get_bind()
    if isinstance(bind, Engine) and bind.dialect.name == "postgresql":
        return Session(bind)
    return None


def run_forecasts(
    session: Session,
    options: ForecastOptions | None = None,
    *,
    progress: Progress | None = None,
    at: datetime | None = None,
) -> FleetRun:
    """Forecast every registered car from its stored history; append one Forecast row each.

    On PostgreSQL reading (own connection, thread), computing (this thread) and writing
    (``session``, thread) overlap, chunk by chunk (see :mod:`service.fleet.pipeline`).
    """
    options = options or ForecastOptions()
    bands = load_bands(session)
    known = set(session.scalars(select(Car.id)))
    reader = _reader_session(session)
    with contextlib.ExitStack() as stack:
        if reader is None:
            stream: Iterator[CarHistory] = histories(session, bands.names)
            write: Callable[[list[dict[str, Any]]], None] = partial(write_forecasts, session)
        else:
            stack.enter_context(reader)
            stream = read_ahead(lambda: histories(reader, bands.names), depth=_READ_AHEAD)
            stack.callback(stream.close)  # type: ignore[attr-defined]
            write = stack.enter_context(Writer(partial(write_forecasts, session), depth=2)).submit
        run = _assess_all(stream, known, bands, options, write, progress, at)
    session.flush()
    return run


def _assess_all(
    stream: Iterator[CarHistory],
    known: set[str],
    bands: Bands,
    options: ForecastOptions,
    write: Callable[[list[dict[str, Any]]], None],
    progress: Progress | None,
    at: datetime | None,
) -> FleetRun:
    # One pass: the first cars calibrate the fleet index, then are assessed with the rest.
    sample = list(itertools.islice(stream, SAMPLE_CARS))
    fleet = calibrate_fleet_index(sample, bands, options)
    run = FleetRun(computed_at=at or utcnow(), calibration=fleet.note)
    pending: list[dict[str, Any]] = []
    seen: set[str] = set()
    ranked: list[tuple[tuple[Any, ...], str, float]] = []

    def emit(history: CarHistory, outcome: Outcome | None = None) -> None:
        nonlocal pending
        row = forecast_row(history, bands, fleet, options, run.computed_at, outcome)
        pending.append(row)
        seen.add(history.car_id)
        run.statuses[row["status"]] = run.statuses.get(row["status"], 0) + 1
        if row["risk"] is not None:
            key = rank_key(row["status"], row["risk"], row["payload"])
            ranked.append((key, history.car_id, row["risk"]))
        if len(pending) >= _WRITE_CHUNK:
            write(pending)
            pending = []  # the writer owns the submitted list
        if progress is not None:
            progress(len(seen), len(known))

    for chunk in _chunks(itertools.chain(sample, stream)):
        # the foreign key makes membership always true; be safe anyway
        chunk = [h for h in chunk if h.car_id in known]
        for i, outcome in outcomes(chunk, bands, fleet, options).items():
            emit(chunk[i], outcome)
    for car_id in sorted(known - seen):
        emit(empty_history(car_id))
    write(pending)
    run.cars = len(seen)
    # the fleet view's order: most severe recommendation first, then risk
    run.top = [(car, risk) for _, car, risk in sorted(ranked)[:TOP_CARS]]
    return run


def outcomes(
    chunk: list[CarHistory], bands: Bands, fleet: FleetIndex, options: ForecastOptions
) -> dict[int, Outcome]:
    """Each car's outcome (in chunk order): vectorised where it can be, per car otherwise."""
    batch = batch_assessments(
        chunk, bands, fleet, order=options.order, horizon=options.horizon,
        failure_k=options.failure_k,
    )  # fmt: skip
    return {
        i: assessed(batch[i], fleet.note) if i in batch else _outcome(h, bands, fleet, options)
        for i, h in enumerate(chunk)
    }


def _chunks(stream: Iterable[CarHistory]) -> Iterator[list[CarHistory]]:
    iterator = iter(stream)
    while chunk := list(itertools.islice(iterator, _COMPUTE_CHUNK)):
        yield chunk


def write_forecasts(session: Session, rows: list[dict[str, Any]]) -> None:
    """Insert Forecast rows (from :func:`forecast_row`) in bulk; ``rows`` is emptied."""
    if not rows:
        return
    if session.get_bind().dialect.name != "postgresql":
        safe = [{**r, "payload": _finite(r["payload"])} for r in rows]
        session.connection().execute(insert(Forecast), safe)
        rows.clear()
        return
    # COPY: the server parses text rows far cheaper than bound INSERT parameters, and psycopg
    # formats them in C, so the writer thread holds the GIL the computation needs only briefly.
    # The payload is encoded once here (NaN/inf, rare, become null); ids come from the sequence.
    driver = session.connection().connection.driver_connection
    with driver.cursor() as cursor, cursor.copy(_COPY) as copy:  # type: ignore[union-attr]
        for r in rows:
            copy.write_row(
                (r["car_id"], r["computed_at"], r["status"], r["risk"], _encoded(r["payload"]))
            )
    rows.clear()


def _encoded(payload: dict[str, Any]) -> str:
    # orjson writes NaN/inf as null, as _finite does, several times faster than json: the
    # encoding runs in the writer thread and holds the GIL the computation needs.
    try:
        return orjson.dumps(payload).decode()
    except TypeError:  # a type orjson does not know (e.g. a numpy scalar in a payload)
        return json.dumps(_finite(payload), allow_nan=False, default=float)


_COPY = "COPY forecasts (car_id, computed_at, status, risk, payload) FROM STDIN"
