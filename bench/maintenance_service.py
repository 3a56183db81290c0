"""End-to-end fleet forecast job: read stored histories, assess, write forecasts (cars/s).

Run: .venv/bin/python -m bench.maintenance_service [--cars 10000] [--tests 200] [--limit 900]

A fresh PostgreSQL database (SQLite when PostgreSQL is unreachable) is migrated and filled
with N cars × 20 parameters × 200 bench tests (``maintenance.simulate``, bulk-loaded with a
binary COPY on PostgreSQL, never through the API). Then, as ``depot forecast`` does:

* the phases on their own (in a transaction rolled back afterwards): reading every history
  (``service.fleet.history.histories``), computing the outcomes (vectorised assessment, payload
  rows) and writing the forecast rows;
* ``service.fleet.forecasts.run_forecasts`` end to end, committed.

Prints cars per second of each (wall clock; and the job process's CPU time, as the machine may
be shared: PostgreSQL's own work runs in its server process), and the end-to-end rate as a share
of the compute-alone rate, measured side by side in this run. Issue 15's target: end to end
≥ 0.75× compute alone at 10,000 cars on PostgreSQL (reading, computing and writing overlap).
The whole run is bounded by ``--limit`` seconds (SIGALRM).
"""

from __future__ import annotations

import argparse
import os
import signal
import time
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

import numpy as np
from sqlalchemy import create_engine, insert, text
from sqlalchemy.orm import Session

from bench._server import bench_database
from core.database import make_engine
from core.models import Car
from maintenance.simulate import PARAMETERS, simulate_fleet
from service.fleet import forecasts
from service.fleet.calibration import SAMPLE_CARS
from service.fleet.history import histories, load_bands
from service.fleet.models import (
    READINGS_DTYPE,
    Measurement,
    Parameter,
    encode_readings,
)
from service.fleet.service import layout_id
from service.migrate import upgrade

ROOT = Path(__file__).resolve().parents[1]
END = datetime(2026, 11, 23, tzinfo=UTC)
PG_EPOCH = datetime(2000, 1, 1, tzinfo=UTC)
DATABASE = "depot_bench_maint"
SIM_CHUNK = 500  # cars simulated (and copied) at a time: memory stays flat


def _copy_dtype(n_params: int) -> np.dtype[Any]:
    """One binary COPY tuple of (car_id, taken_at, layout_id, readings, source), fixed size."""
    return np.dtype([
        ("fields", ">i2"), ("car_len", ">i4"), ("car", "S6"), ("at_len", ">i4"), ("at", ">i8"),
        ("layout_len", ">i4"), ("layout", ">i4"), ("readings_len", ">i4"),
        ("readings", READINGS_DTYPE, (n_params,)), ("source_len", ">i4"), ("source", "S5"),
    ])  # fmt: skip


def _copy_block(histories_: np.ndarray, first_car: int, layout: int, at_us: np.ndarray) -> bytes:
    n_cars, n_tests, n_params = histories_.shape
    rec = np.zeros(n_cars * n_tests, dtype=_copy_dtype(n_params))
    rec["fields"], rec["car_len"], rec["at_len"], rec["layout_len"] = 5, 6, 8, 4
    rec["car"] = np.repeat([f"C{c:05d}".encode() for c in range(first_car, first_car + n_cars)],
                           n_tests)  # fmt: skip
    rec["at"] = np.tile(at_us, n_cars)
    rec["layout"] = layout
    rec["readings_len"] = 8 * n_params
    rec["readings"] = histories_.reshape(-1, n_params)
    rec["source_len"], rec["source"] = 5, b"bench"
    return rec.tobytes()


def fill(session: Session, n_cars: int, n_tests: int) -> int:
    """Parameters, cars and every car's tests; returns the number of tests stored."""
    session.add_all(Parameter(name=n, nominal=c, tolerance=t, unit="") for n, c, t, _ in PARAMETERS)
    session.add_all(Car(id=f"C{c:05d}", axles=4) for c in range(n_cars))
    session.flush()
    times = [END - timedelta(days=n_tests - i) for i in range(n_tests)]
    at_us = np.array([(t - PG_EPOCH) // timedelta(microseconds=1) for t in times], np.int64)
    postgres = session.get_bind().dialect.name == "postgresql"
    copy_sql = ("COPY measurements (car_id, taken_at, layout_id, readings, source)"
                " FROM STDIN (FORMAT BINARY)")  # fmt: skip
    driver = session.connection().connection.driver_connection
    cursor = driver.cursor() if postgres and driver is not None else None
    for start in range(0, n_cars, SIM_CHUNK):
        size = min(SIM_CHUNK, n_cars - start)
        fleet = simulate_fleet(size, n_times=n_tests, seed=1 + start)
        order = np.argsort(fleet.names)  # readings follow the layout's sorted names
        layout = layout_id(session, [fleet.names[j] for j in order])
        data = fleet.histories[:, :, order]
        if cursor is not None:
            with cursor.copy(copy_sql) as copy:
                copy.write(b"PGCOPY\n\xff\r\n\x00" + bytes(8))
                copy.write(_copy_block(data, start, layout, at_us))
                copy.write(b"\xff\xff")
            continue
        rows = [
            {"car_id": f"C{start + c:05d}", "taken_at": times[i], "layout_id": layout,
             "readings": encode_readings(data[c, i]), "source": "bench"}
            for c in range(size) for i in range(n_tests)
        ]  # fmt: skip
        session.connection().execute(insert(Measurement), rows)
    return n_cars * n_tests


def phases(session: Session) -> dict[str, float]:
    """Seconds spent reading, computing and writing, the job's loop taken apart."""
    spent = {"read": 0.0, "compute": 0.0, "write": 0.0}
    options, at = forecasts.ForecastOptions(), datetime.now(UTC)
    bands = load_bands(session)
    stream, fleet, chunk = histories(session, bands.names), None, []
    while True:
        started = time.perf_counter()
        history = next(stream, None)
        spent["read"] += time.perf_counter() - started
        if history is not None:
            chunk.append(history)
        if len(chunk) < (SAMPLE_CARS if fleet is None else 1000) and history is not None:
            continue
        started = time.perf_counter()
        if fleet is None:
            fleet = forecasts.calibrate_fleet_index(chunk, bands, options)
        outcome = forecasts.outcomes(chunk, bands, fleet, options)
        rows = [forecasts.forecast_row(chunk[i], bands, fleet, options, at, o)
                for i, o in outcome.items()]  # fmt: skip
        spent["compute"] += time.perf_counter() - started
        started = time.perf_counter()
        for first in range(0, len(rows), 500):
            forecasts.write_forecasts(session, rows[first : first + 500])
        spent["write"] += time.perf_counter() - started
        chunk = []
        if history is None:
            return spent


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cars", type=int, default=10_000)
    parser.add_argument("--tests", type=int, default=200)
    parser.add_argument("--limit", type=int, default=900, help="abort after this many seconds")
    args = parser.parse_args()
    signal.alarm(args.limit)  # bounded: SIGALRM ends the run
    url = bench_database(DATABASE)
    upgrade(url)
    engine = make_engine(url)
    started = time.perf_counter()
    with Session(engine) as session, session.begin():
        tests = fill(session, args.cars, args.tests)
    if engine.dialect.name == "postgresql":
        with engine.connect() as connection:  # as autovacuum would after a bulk load
            connection.execute(text("ANALYZE measurements"))
            connection.commit()
    print(f"{engine.dialect.name}: stored {tests:,} tests ({tests * len(PARAMETERS):,} values) "
          f"of {args.cars:,} cars in {time.perf_counter() - started:.1f} s")  # fmt: skip
    print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores (others' work "
          "slows every figure below)")  # fmt: skip
    cpu = time.process_time()
    with Session(engine) as session:
        spent = phases(session)
        session.rollback()
    print(f"phases (rolled back), wall clock; job process CPU {time.process_time() - cpu:.2f} s:")
    for phase, seconds in spent.items():
        print(f"  {phase:8s} {seconds:6.2f} s = {args.cars / seconds:8,.0f} cars/s")
    started, cpu = time.perf_counter(), time.process_time()
    with Session(engine) as session, session.begin():
        run = forecasts.run_forecasts(session)
    elapsed, cpu = time.perf_counter() - started, time.process_time() - cpu
    print(f"forecast job end to end: {run.cars:,} cars in {elapsed:.2f} s = "
          f"{run.cars / elapsed:,.0f} cars/s; job process CPU {cpu:.2f} s = "
          f"{run.cars / cpu:,.0f} cars per CPU-second; {run.statuses}")  # fmt: skip
    compute = args.cars / spent["compute"]
    print(f"end to end {run.cars / elapsed:,.0f} cars/s beside compute alone {compute:,.0f} "
          f"cars/s: ratio {run.cars / elapsed / compute:.2f} (target ≥ 0.75)")  # fmt: skip
    print(run.calibration)
    engine.dispose()
    if url.startswith("postgresql"):  # drop the bench database (~1 GB at 10,000 cars)
        admin = create_engine(url.rsplit("/", 1)[0] + "/postgres", isolation_level="AUTOCOMMIT")
        with admin.connect() as connection:
            connection.execute(text(f'DROP DATABASE IF EXISTS "{DATABASE}" WITH (FORCE)'))
        admin.dispose()


if __name__ == "__main__":
    main()
