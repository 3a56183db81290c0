"""The CSV import's memory is bounded by the tests it must remember, not by the file.

An independent trial imported a 50 MB CSV of car measurements and saw 2.1 GB RSS: every row
was kept as strings, every test as a dict of (value, line) tuples, then as a list of tests,
then as insert rows, and every stored test of those cars was loaded at once. The import still
refuses the whole file on any error — the transaction rolls back what earlier chunks stored.
"""

from __future__ import annotations

import os
import random
import subprocess
import sys
from datetime import UTC, datetime, timedelta
from pathlib import Path

import pytest
import sqlalchemy as sa
from sqlalchemy.orm import Session

from core.models import Car
from service.fleet import importing
from service.fleet.models import Parameter
from service.migrate import upgrade
from tests.service.fleetkit import measurement_count
from tests.service.test_service_fleet_cli import WIDE, _csv, db, depot

# The shared fixture (pytest finds a fixture by its module's names).
db = db

# A bench's parameters: name, nominal, tolerance (seconds, ohms, bar).
BENCH = (
    ("door_close_s", 2.4, 0.5),
    ("brake_release_s", 4.0, 1.0),
    ("brake_cylinder_fill_s", 5.0, 1.5),
    ("compressor_fill_s", 180.0, 20.0),
    ("insulation_mohm", 40.0, 10.0),
    ("brake_pipe_bar", 5.0, 0.2),
)
CARS = [f"{n:04d}" for n in range(101, 261)]  # 160 cars
ROWS = 240_000  # 1,500 tests a car: a few years of daily bench tests
# Peak RSS growth the import may take per value it must remember (its value, line and test),
# on top of a fixed allowance for the chunk in flight and SQLite's page cache. The old import
# took ≈ 600 bytes per value here; the streaming one ≈ 40.
BYTES_PER_VALUE = 150
FIXED_BYTES = 40 * 2**20


def _write_bench_csv(path: Path, rows: int, *, seed: int, year: int) -> int:
    """A realistic wide export: cars tested in turn, a few cells not measured, noisy values
    with 2–4 decimals, some times with the depot's local offset. Returns the values written."""
    rng = random.Random(seed)
    start = datetime(year, 3, 1, 6, 0, tzinfo=UTC)
    local = timedelta(hours=2)
    values = 0
    with path.open("w", encoding="utf-8", newline="") as out:
        out.write("car,taken_at," + ",".join(name for name, _, _ in BENCH) + "\n")
        for i in range(rows):
            car = CARS[i % len(CARS)]
            at = start + timedelta(days=i // len(CARS), minutes=7 * (i % len(CARS)))
            stamp = (
                at.isoformat().replace("+00:00", "Z")
                if i % 3
                else (at + local).replace(tzinfo=None).isoformat() + "+02:00"
            )
            cells = []
            for _, nominal, tolerance in BENCH:
                if rng.random() < 0.08:  # not measured at this test
                    cells.append("")
                    continue
                values += 1
                cells.append(f"{rng.gauss(nominal, tolerance / 2):.{rng.choice((2, 3, 4))}f}")
            out.write(f"{car},{stamp},{','.join(cells)}\n")
    return values


def _peak_rss(argv: list[str], env: dict[str, str]) -> tuple[int, str]:
    """Run ``depot`` in a child; its own peak RSS in bytes (wait4, not all children's) and
    its output."""
    child = subprocess.Popen(
        [sys.executable, "-m", "service.cli", *argv],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    assert child.stdout is not None
    output = child.stdout.read()
    _, status, usage = os.wait4(child.pid, 0)
    child.returncode = os.waitstatus_to_exitcode(status)
    assert child.returncode == 0, output
    return usage.ru_maxrss * 1024, output  # Linux reports KiB


@pytest.fixture
def bench_db(tmp_path: Path) -> dict[str, str]:
    """A migrated SQLite file with the bench's cars and parameters; the child's environment."""
    url = f"sqlite:///{tmp_path / 'depot.sqlite3'}"
    upgrade(url)
    engine = sa.create_engine(url)
    with Session(engine) as session:
        session.add_all(Car(id=car, axles=4) for car in CARS)
        session.add_all(
            Parameter(name=name, nominal=nominal, tolerance=tolerance, unit="s")
            for name, nominal, tolerance in BENCH
        )
        session.commit()
    engine.dispose()
    return {**os.environ, "DEPOT_DATABASE_URL": url, "DEPOT_DATA_DIR": str(tmp_path)}


def test_import_memory_grows_with_the_tests_not_with_the_rows_kept(
    bench_db: dict[str, str], tmp_path: Path
) -> None:
    small, big = tmp_path / "small.csv", tmp_path / "big.csv"
    _write_bench_csv(small, 20, seed=1, year=2020)
    values = _write_bench_csv(big, ROWS, seed=7, year=2021)
    baseline, _ = _peak_rss(["import-measurements", str(small)], bench_db)
    peak, output = _peak_rss(["import-measurements", str(big)], bench_db)
    assert f"imported {ROWS} tests ({values} measurements)" in output, output
    growth = peak - baseline
    bound = BYTES_PER_VALUE * values + FIXED_BYTES
    assert growth < bound, (
        f"the import of {big.stat().st_size / 2**20:.0f} MB ({values} values) grew the peak RSS"
        f" by {growth / 2**20:.0f} MB, more than {bound / 2**20:.0f} MB"
    )
