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
from datetime import UTC, datetime, timedelta, timezone
from pathlib import Path

import pytest
import sqlalchemy as sa
from sqlalchemy.orm import Session

from core.models import Car
from service.fleet import importing
from service.fleet import service as fleet_service
from service.fleet.models import Parameter
from service.migrate import upgrade
from tests.service import fleetkit
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
ROWS = 200_000  # 1,250 tests a car: a few years of daily bench tests (12 MB)
# Peak RSS growth the import may take per value it must remember (its value, line and test),
# on top of a fixed allowance for the chunk in flight and SQLite's page cache. The import that
# kept every row took ≈ 370 bytes per value here (393 MB), the streaming one ≈ 54 (57 MB).
BYTES_PER_VALUE = 100
FIXED_BYTES = 32 * 2**20


def _write_bench_csv(path: Path, rows: int, *, seed: int, year: int) -> int:
    """A realistic wide export: cars tested in turn, a few cells not measured (8 %), noisy
    values with 2–4 decimals, a third of the times with the depot's local offset. Returns the
    values written."""
    rng = random.Random(seed)
    # Each parameter's readings drawn from a pool (formatting every one would take seconds).
    pools = [
        [f"{rng.gauss(nominal, tolerance / 2):.{rng.choice((2, 3, 4))}f}" for _ in range(4096)]
        for _, nominal, tolerance in BENCH
    ]
    start = datetime(year, 3, 1, 6, 0, tzinfo=UTC)
    local = timezone(timedelta(hours=2))
    values = 0
    with path.open("w", encoding="utf-8", newline="") as out:
        out.write("car,taken_at," + ",".join(name for name, _, _ in BENCH) + "\n")
        for i in range(rows):
            at = start + timedelta(days=i // len(CARS), minutes=7 * (i % len(CARS)))
            stamp = at.isoformat() if i % 3 else at.astimezone(local).isoformat()
            cells = [pool[rng.getrandbits(12)] if rng.random() >= 0.08 else "" for pool in pools]
            values += sum(1 for cell in cells if cell)
            out.write(f"{CARS[i % len(CARS)]},{stamp.replace('+00:00', 'Z')},{','.join(cells)}\n")
    return values


# Run in a child: a small import first (every module loaded, the engine made), then the peak
# RSS is reset to the resident size (Linux: /proc/self/clear_refs) and the big file imported.
_CHILD = """
import re, sys
from service.cli import main

def status(field):
    text = open("/proc/self/status").read()
    return int(re.search(field + r":\\s*(\\d+) kB", text).group(1)) * 1024

assert main(["import-measurements", sys.argv[1]]) == 0
resident = status("VmRSS")
with open("/proc/self/clear_refs", "w") as clear:
    clear.write("5")
code = main(["import-measurements", sys.argv[2]])
print("peak growth", status("VmHWM") - resident)
sys.exit(code)
"""


def _peak_growth(small: Path, big: Path, env: dict[str, str]) -> tuple[int, str]:
    """How far the import of ``big`` raised the peak RSS of a warmed-up ``depot`` process
    above its resident size, in bytes; and the output."""
    child = subprocess.run(
        [sys.executable, "-c", _CHILD, str(small), str(big)],
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert child.returncode == 0, child.stdout + child.stderr
    return int(child.stdout.rsplit("peak growth ", 1)[1]), child.stdout


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


@pytest.mark.skipif(not Path("/proc/self/clear_refs").exists(), reason="Linux /proc only")
def test_import_memory_grows_with_the_tests_not_with_the_rows_kept(
    bench_db: dict[str, str], tmp_path: Path
) -> None:
    small, big = tmp_path / "small.csv", tmp_path / "big.csv"
    _write_bench_csv(small, 20, seed=1, year=2020)
    values = _write_bench_csv(big, ROWS, seed=7, year=2021)
    growth, output = _peak_growth(small, big, bench_db)
    assert f"imported {ROWS} tests ({values} measurements)" in output, output
    bound = BYTES_PER_VALUE * values + FIXED_BYTES
    assert growth < bound, (
        f"the import of {big.stat().st_size / 2**20:.0f} MB ({values} values) grew the peak RSS"
        f" by {growth / 2**20:.0f} MB, more than {bound / 2**20:.0f} MB"
    )


# -- all rows or none, a chunk at a time ----------------------------------------------------


def _bench_rows(count: int, value: str = "2.41", offset: timedelta = timedelta(0)) -> str:
    """``count`` tests of car 0117 a day apart (door and brake), in the CLI tests' header,
    their times written with ``offset``."""
    start = datetime(2026, 9, 1, 7, 30, tzinfo=UTC)
    zone = timezone(offset)
    days = [(start + timedelta(days=day)).astimezone(zone) for day in range(count)]
    lines = [f"0117,{day.isoformat()},{value},4.02" for day in days]
    return WIDE.splitlines()[0] + "\n" + "\n".join(lines) + "\n"


def test_a_conflict_found_after_chunks_were_written_rolls_them_back(
    db, session: Session, tmp_path: Path, capsys, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Another import stores the file's 6th test with other values after this one looked (the
    look is made to miss it): chunks of two were already written when the insert finds it, and
    the refusal leaves none of them."""
    monkeypatch.setattr(importing, "LIMITS", importing.ImportLimits(chunk=2))
    path = _csv(tmp_path, _bench_rows(9))
    before = measurement_count(session)
    sixth = datetime(2026, 9, 6, 7, 30, tzinfo=UTC)
    fleet_service.record_measurements(
        session, "0117", sixth, {"door_close_s": 2.6, "brake_release_s": 4.02}, source="api"
    )
    real = importing._stored_marks
    monkeypatch.setattr(importing, "_stored_marks", lambda s, tests: bytearray(len(tests)))
    assert depot("import-measurements", path) == 2
    err = capsys.readouterr().err
    assert f"car 0117 at {sixth.isoformat()} is stored with other values" in err, err
    assert measurement_count(session) == before + 1  # the other import's test only
    monkeypatch.setattr(importing, "_stored_marks", real)
    assert depot("import-measurements", path) == 2  # the ordinary look refuses it as well
    assert measurement_count(session) == before + 1


def test_a_reimport_in_chunks_skips_every_stored_test_and_counts_the_conflicts(
    db, session: Session, tmp_path: Path, capsys, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(importing, "LIMITS", importing.ImportLimits(chunk=3))
    path = _csv(tmp_path, _bench_rows(10))
    assert depot("import-measurements", path) == 0
    assert "imported 10 tests (20 measurements)" in capsys.readouterr().out
    assert depot("import-measurements", path) == 0
    again = capsys.readouterr().out
    assert "imported 0 tests (0 measurements)" in again and "10 already stored, skipped" in again
    # The same instants written in local time are the same tests: 2.42 contradicts all ten.
    local = _bench_rows(10, "2.42", offset=timedelta(hours=2))
    assert depot("import-measurements", _csv(tmp_path, local)) == 2
    err = capsys.readouterr().err
    assert err.count("is stored with other values") == 5 and "; … and 5 more — correct" in err
    assert measurement_count(session) == 10


def test_many_bad_lines_are_listed_five_then_counted(db, session: Session, tmp_path) -> None:
    """The first five errors in the order of the checks (header, unnamed columns, split
    decimals — decided by a point written further down —, then each line), the rest counted."""
    text = (
        "car,taken_at,door_close_s,brake_release_s,\n"
        "0117,2026-11-01T07:30:00Z,2,45,\n"  # 2,45 split: the door column writes points below
        "0117,2026-11-02T07:30:00Z,2.4,4.1,7\n"  # a value under the unnamed column
        "0117,2026-11-03T07:30:00Z,abc,4.1,\n"
        "0117,2026-11-04T07:30:00Z,2.4,99,\n"
        "0118,2026-11-04T07:30:00Z,2.4\n"
        "0118,yesterday,2.4,4.1,\n"
        "0117,2026-11-01T07:30:00Z,2.5,,\n"  # contradicts line 2's door 2 s
        "0118,2026-11-05T07:30:00Z,3,05,\n"  # 3,05 split whatever the column writes
    )
    detail = fleetkit.refusal(session, text)
    shown = detail.split(" — fix these lines")[0].split("; … and ")
    assert shown[1] == "4 more", detail
    assert [error.split(":")[0] for error in shown[0].split("; line")] == [
        "line 3, column 5 (no name in the header)",
        " 2, columns door_close_s and brake_release_s",
        " 9, columns door_close_s and brake_release_s",
        " 2, column brake_release_s",  # 45 s: the split's fraction
        " 4, column door_close_s",
    ], detail
