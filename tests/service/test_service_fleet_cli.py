"""``depot import-measurements`` and ``depot forecast``, and the in-process schedule."""

from __future__ import annotations

import argparse
import threading
import time
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import func, select
from sqlalchemy.orm import Session, sessionmaker

from service.commands import fleet as commands
from service.fleet import schedule
from service.fleet.models import Forecast, Measurement
from service.fleet.service import measured_values
from tests.conftest import ADMIN
from tests.service.linekit import build_line, register_bands

WIDE = """car,taken_at,door_close_s,brake_release_s
0117,2026-11-01T07:30:00Z,2.41,4.02
0117,2026-11-03T07:30:00+00:00,2.45,
0118,2026-11-01T08:00:00Z,2.38,3.97
"""


@pytest.fixture
def db(client: TestClient, session: Session, monkeypatch: pytest.MonkeyPatch) -> sessionmaker:
    """The CLI's sessions on the test's connection, inside its rolled-back transaction."""
    build_line(client)
    register_bands(client)
    factory = sessionmaker(bind=session.connection(), join_transaction_mode="create_savepoint")
    monkeypatch.setattr(commands, "get_sessionmaker", lambda: factory)
    return factory


def depot(*argv: str) -> int:
    parser = argparse.ArgumentParser()
    commands.register(parser.add_subparsers(dest="command"))
    args = parser.parse_args(list(argv))
    return int(args.func(args))


def _csv(tmp_path: Path, text: str) -> str:
    path = tmp_path / "bench.csv"
    path.write_text(text, encoding="utf-8")
    return str(path)


def _count(session: Session) -> int:
    return session.scalar(select(func.count()).select_from(Measurement)) or 0


def test_import_wide_csv(db, session: Session, tmp_path: Path, capsys) -> None:
    assert depot("import-measurements", _csv(tmp_path, WIDE)) == 0
    assert "imported 3 tests (5 measurements)" in capsys.readouterr().out
    rows = session.scalars(select(Measurement).order_by(Measurement.id)).all()
    assert len(rows) == 3  # one row per test
    assert (rows[0].car_id, measured_values(session, rows[0]), rows[0].source) == (
        "0117",
        {"door_close_s": 2.41, "brake_release_s": 4.02},
        "csv",
    )


def test_import_long_csv(db, session: Session, tmp_path: Path, capsys) -> None:
    text = "car,taken_at,parameter,value\n0119,2026-11-01T07:30:00Z,door_close_s,2.5\n"
    assert depot("import-measurements", _csv(tmp_path, text)) == 0
    assert _count(session) == 1


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("car,when,door_close_s\n0117,2026-11-01T07:30:00Z,2.4\n", "lacks the column(s) taken_at"),
        (WIDE.replace("2.38", "abc"), "line 4, column door_close_s: 'abc' is not a finite number"),
        (WIDE.replace("4.02", "nan"), "line 2, column brake_release_s"),
        (WIDE.replace("0118", "9999"), "unknown car(s) 9999; register them"),
        (WIDE.replace("2026-11-01T08:00:00Z", "2026-11-01 08:00"), "has no offset"),
        (WIDE.replace("2026-11-01T08:00:00Z", "yesterday"), "'yesterday' is not an ISO 8601"),
        ("car,taken_at,door_close_s\n", "holds no measurements"),
        # the cases: a misspelt column, a decimal comma, an implausible value
        (
            WIDE.replace("door_close_s", "door_closse_s"),
            "column door_closse_s: 'door_closse_s'"
            " is not a registered parameter; did you mean 'door_close_s'?",
        ),
        (
            WIDE.replace("2.41,4.02", "3,1,4.02"),
            "line 2: 5 fields for 4 columns — a decimal comma?",
        ),
        (
            WIDE.replace("0118,2026-11-01T08:00:00Z,2.38,3.97", "0118,2026-11-01T08:00:00Z,2.38"),
            "line 4: fewer fields than the 4 columns",
        ),
        # numbers only Python's float reads, and a test dated years ahead (data rules)
        (WIDE.replace("2.38", "2.3_8"), "line 4, column door_close_s: '2.3_8' is not a finite"),
        (WIDE.replace("4.02", "٤.٠٢"), "line 2, column brake_release_s: '٤.٠٢' is not a finite"),
        (
            WIDE.replace("2026-11-03T07:30:00+00:00", "2096-11-03T07:30:00+00:00"),
            "line 3: taken_at 2096-11-03T07:30:00Z is",
        ),
        (
            WIDE.replace("2.45", "3e9"),
            "line 3, column door_close_s: door_close_s = 3e+09 s is"
            " outside its plausible range 0…7.4 s",
        ),
    ],
)
def test_bad_csv_is_refused_whole(
    db, session: Session, tmp_path: Path, capsys, text, expected
) -> None:
    assert depot("import-measurements", _csv(tmp_path, text)) == 2
    err = capsys.readouterr().err
    assert expected in err, err
    assert _count(session) == 0  # nothing imported


def test_importing_the_same_file_again_stores_nothing_twice(
    db, session: Session, tmp_path: Path, capsys
) -> None:
    path = _csv(tmp_path, WIDE)
    assert depot("import-measurements", path) == 0
    capsys.readouterr()
    assert depot("import-measurements", path) == 0
    again = capsys.readouterr().out
    assert "imported 0 tests (0 measurements)" in again and "3 already stored, skipped" in again
    assert _count(session) == 3
    changed = _csv(tmp_path, WIDE.replace("2.41", "2.42"))
    assert depot("import-measurements", changed) == 2
    assert "car 0117 at 2026-11-01T07:30:00+00:00 is stored with other values" in (
        capsys.readouterr().err
    )
    assert _count(session) == 3


def test_missing_file(db, tmp_path: Path, capsys) -> None:
    assert depot("import-measurements", str(tmp_path / "none.csv")) == 2
    assert "does not exist" in capsys.readouterr().err


def test_forecast_command_shows_progress(db, session: Session, capsys) -> None:
    assert depot("forecast", "--horizon", "10") == 0
    captured = capsys.readouterr()
    assert "[" + "#" * 30 + "] 4/4 cars" in captured.err
    assert "forecast 4 cars" in captured.out and "4 not_enough_history" in captured.out
    assert session.scalar(select(func.count()).select_from(Forecast)) == 4
    with pytest.raises(SystemExit):
        depot("forecast", "--method", "magic")


def test_schedule_repeats_and_survives_a_failing_round() -> None:
    calls: list[int] = []
    done = threading.Event()

    def job() -> None:
        calls.append(1)
        if len(calls) == 1:
            raise RuntimeError("database away")
        if len(calls) >= 3:
            done.set()

    timer = schedule.ForecastSchedule(0.01, job)
    timer.start()
    assert done.wait(5.0)
    timer.stop()
    assert len(calls) >= 3 and not timer._thread.is_alive()


def test_scheduled_round_writes_forecasts(db, session: Session) -> None:
    run = schedule.scheduled_forecast(db)
    assert run is not None and run.cars == 4
    assert session.scalar(select(func.count()).select_from(Forecast)) == 4


def test_lifespan_starts_the_schedule_only_when_configured(
    app, db, monkeypatch: pytest.MonkeyPatch
) -> None:
    with TestClient(app):
        assert app.state.forecast_schedule is None
    rounds = threading.Event()
    monkeypatch.setattr(schedule, "get_sessionmaker", lambda: db)
    monkeypatch.setattr(schedule, "scheduled_forecast", lambda factory: rounds.set())
    settings = schedule.get_settings().model_copy(update={"forecast_every": 0.01})
    monkeypatch.setattr(schedule, "get_settings", lambda: settings)
    with TestClient(app) as client:
        timer = app.state.forecast_schedule
        assert timer is not None and rounds.wait(5.0)
        assert client.get("/api/v1/maintenance/fleet", headers=ADMIN).status_code == 200
    time.sleep(0.05)
    assert not timer._thread.is_alive()
