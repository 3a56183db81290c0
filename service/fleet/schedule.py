"""The in-process forecast schedule (``DEPOT_FORECAST_EVERY`` seconds) and the app's lifespan."""

from __future__ import annotations

import logging
import threading
from collections.abc import AsyncIterator, Callable
from contextlib import asynccontextmanager
from typing import Any

from fastapi import FastAPI
from sqlalchemy import text
from sqlalchemy.orm import Session, sessionmaker

from core.database import get_sessionmaker
from core.settings import get_settings
from service.fleet.forecasts import FleetRun, ForecastOptions, run_forecasts

log = logging.getLogger("depot.fleet.schedule")
# Several server workers each run a schedule; on PostgreSQL one transaction-level advisory lock
# lets exactly one of them compute a round (the others skip it) instead of repeating the work.
ADVISORY_LOCK = 0x64_65_70_6F_74_46  # "depotF"


def scheduled_forecast(factory: sessionmaker[Session]) -> FleetRun | None:
    """One scheduled round, committed; None when another worker holds the round."""
    with factory.begin() as session:
        if session.get_bind().dialect.name == "postgresql":
            locked = session.scalar(
                text("SELECT pg_try_advisory_xact_lock(:k)"), {"k": ADVISORY_LOCK}
            )
            if not locked:
                return None
        run = run_forecasts(session, ForecastOptions())
    log.info("scheduled forecast: %d cars, %s", run.cars, run.statuses)
    return run


class ForecastSchedule:
    """Calls ``job`` every ``every`` seconds on a daemon thread until stopped."""

    def __init__(self, every: float, job: Callable[[], Any]) -> None:
        self.every = every
        self.job = job
        self.rounds = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._loop, name="forecast-schedule", daemon=True)

    def start(self) -> None:
        self._thread.start()

    def stop(self, timeout: float = 30.0) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join(timeout)

    def _loop(self) -> None:
        while not self._stop.wait(self.every):
            try:
                self.job()
            except Exception:
                log.exception("scheduled forecast failed")
            self.rounds += 1


@asynccontextmanager
async def lifespan(app: FastAPI) -> AsyncIterator[None]:
    """Run the forecast schedule for the app's lifetime when ``DEPOT_FORECAST_EVERY`` is set."""
    every = get_settings().forecast_every
    schedule = None
    if every:
        factory = get_sessionmaker()
        schedule = ForecastSchedule(every, lambda: scheduled_forecast(factory))
        schedule.start()
        log.info("forecasts scheduled every %g s", every)
    app.state.forecast_schedule = schedule
    try:
        yield
    finally:
        if schedule is not None:
            schedule.stop()
