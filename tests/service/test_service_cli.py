"""The ``depot`` command line on its own embedded database."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import text

from core import database
from core.database import make_engine
from core.settings import get_settings
from service.cli import main
from tests.conftest import BACKENDS, POSTGRES_URL


@pytest.fixture
def cli_data_dir(tmp_path: Path) -> Iterator[Path]:
    saved = {k: os.environ.get(k) for k in ("DEPOT_DATA_DIR", "DEPOT_DATABASE_URL")}
    os.environ["DEPOT_DATA_DIR"] = str(tmp_path)
    os.environ.pop("DEPOT_DATABASE_URL", None)
    for cache in (get_settings, database.get_engine, database.get_sessionmaker):
        cache.cache_clear()
    yield tmp_path
    database.get_engine().dispose()
    for key, value in saved.items():
        if value is None:
            os.environ.pop(key, None)
        else:
            os.environ[key] = value
    for cache in (get_settings, database.get_engine, database.get_sessionmaker):
        cache.cache_clear()


def test_migrate_user_add_and_replay(
    cli_data_dir: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["migrate"]) == 0
    assert (cli_data_dir / "depot.sqlite3").exists()
    assert main(["user", "add", "olena", "--role", "dispatcher"]) == 0
    token = capsys.readouterr().out.strip().splitlines()[-1]
    assert len(token) >= 40
    assert main(["user", "add", "olena", "--role", "engineer"]) == 2
    assert "already exists" in capsys.readouterr().err
    assert main(["replay"]) == 0
    assert "replayed 0 raw events" in capsys.readouterr().out


def test_unknown_role_and_no_command(
    cli_data_dir: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as exit_info:
        main(["user", "add", "ivan", "--role", "driver"])
    assert exit_info.value.code == 2
    assert "invalid choice" in capsys.readouterr().err
    assert main([]) == 2
    assert "serve" in capsys.readouterr().out


def test_demo_loads_once(cli_data_dir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["migrate"]) == 0
    assert main(["demo"]) == 0
    out = capsys.readouterr().out
    assert "'AB': 'alarm'" in out and "'BC': 'review'" in out
    assert main(["demo"]) == 0
    assert "already holds a line" in capsys.readouterr().out
    assert main(["replay"]) == 0
    assert "(0 failed to derive)" in capsys.readouterr().out


def test_user_lifecycle_and_device_commands(
    cli_data_dir: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["migrate"]) == 0
    assert main(["user", "add", "olena", "--role", "dispatcher", "--expires-in-days", "30"]) == 0
    first = capsys.readouterr().out.strip().splitlines()[-1]
    assert main(["user", "rotate", "olena"]) == 0
    second = capsys.readouterr().out.strip().splitlines()[-1]
    assert second != first and len(second) >= 40
    assert main(["user", "list"]) == 0
    listing = capsys.readouterr().out
    assert "olena" in listing and "active" in listing and first not in listing
    assert main(["user", "revoke", "olena"]) == 0
    assert "stops working" in capsys.readouterr().out
    assert main(["user", "list"]) == 0
    assert "revoked" in capsys.readouterr().out
    assert main(["user", "rotate", "nobody"]) == 2
    assert capsys.readouterr().err.startswith("depot: user 'nobody' does not exist")
    assert main(["device", "key", "nope"]) == 2
    assert "device 'nope' does not exist" in capsys.readouterr().err


def test_user_add_refuses_names_the_api_refuses(
    cli_data_dir: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Found by the independent trial: the CLI stored names that the API answers 422 to."""
    assert main(["migrate"]) == 0
    capsys.readouterr()
    for bad in ("olena\tpetrenko", "x" * 65, "Олeна"):  # a tab; too long; a Latin 'e' inside
        assert main(["user", "add", bad, "--role", "dispatcher"]) == 2, bad
        err = capsys.readouterr().err
        assert err.startswith("depot: ") and "name" in err and "letters" in err, err
        assert "\t" not in err and len(err.strip().splitlines()) == 1, err
    assert main(["device", "key", "bad id!"]) == 2
    assert "device id" in capsys.readouterr().err
    assert main(["user", "list"]) == 0
    assert "olena" not in capsys.readouterr().out


def test_demo_prints_a_summary_not_every_request(cli_data_dir: Path) -> None:
    """Found by trying `make run`: the demo printed ~690 client log lines and a warning."""
    env = {**os.environ, "DEPOT_DATA_DIR": str(cli_data_dir)}
    cli = [sys.executable, "-m", "service.cli"]
    assert subprocess.run([*cli, "migrate"], env=env, capture_output=True).returncode == 0
    done = subprocess.run([*cli, "demo"], env=env, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    lines = [line for line in (done.stdout + done.stderr).splitlines() if line.strip()]
    assert len(lines) <= 3, lines[:10]
    assert "HTTP Request" not in done.stderr and "Warning" not in done.stderr, done.stderr
    assert re.search(r"demo: \d{3,} requests through the API, all answered 2xx", done.stdout)


def test_a_settings_error_never_prints_the_tokens(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """pydantic quoted the settings' input, half the admin token included, on stderr (found by
    the independent trial); the message names the setting and the fix, one line, depot: prefix."""
    from core.settings import get_settings

    token = "Zq7" + "h7Qm2-vXc9LpT4wZ_rB6nYk3sJd8FgA1"
    monkeypatch.setenv("DEPOT_ENVIRONMENT", "production")
    monkeypatch.setenv("DEPOT_ADMIN_TOKEN", token)
    monkeypatch.setenv("DEPOT_METRICS_TOKEN", "m3tr1cs-K8pW2qZ7xN4vB9cR6tY")
    monkeypatch.delenv("DEPOT_DATABASE_URL", raising=False)
    get_settings.cache_clear()
    try:
        assert main(["user", "list"]) == 2
    finally:
        get_settings.cache_clear()
    err = capsys.readouterr().err
    assert err.startswith("depot: invalid settings:") and "PostgreSQL" in err, err
    assert "Zq7h7Q" not in err and "m3tr1cs" not in err and "Traceback" not in err, err


def _main_on_database(url: str, command: list[str], monkeypatch: pytest.MonkeyPatch) -> int:
    """``depot COMMAND`` with ``DEPOT_DATABASE_URL`` set to ``url`` (the cached settings,
    engine and sessions forgotten before and after)."""
    from core.database import get_engine, get_sessionmaker
    from core.settings import get_settings

    def forget() -> None:
        for cached in (get_settings, get_engine, get_sessionmaker):
            cached.cache_clear()

    monkeypatch.setenv("DEPOT_DATABASE_URL", url)
    forget()
    try:
        return main(command)
    finally:
        forget()


@pytest.mark.parametrize(
    "url",
    ["postgresql+psycopg://postgres@127.0.0.1:1/none", "postgres://x@y/z"],
    ids=["unreachable", "unknown-scheme"],
)
def test_a_database_that_cannot_be_used_is_one_clear_line(
    url: str, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A SQLAlchemy traceback with no hint (found by the second trial) is now one depot: line
    that names the setting and the fix."""
    assert _main_on_database(url, ["user", "list"], monkeypatch) == 2
    err = capsys.readouterr().err
    assert err.startswith("depot: the database cannot be used") and "DEPOT_DATABASE_URL" in err
    assert "Traceback" not in err


@pytest.mark.parametrize("command", [["user", "list"], ["migrate"], ["serve"], ["replay"]])
@pytest.mark.parametrize("url", ["mysql://depot@db/depot", "oracle+oracledb://depot@db/depot"])
def test_an_unsupported_database_is_named_with_the_fix(
    url: str,
    command: list[str],
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """An independent trial: a mysql:// URL ended in a traceback (no MySQL driver). depot runs
    on SQLite and PostgreSQL through psycopg: one line names the setting, what it names and
    the fix — and ``serve`` says so before it starts a server."""
    assert _main_on_database(url, command, monkeypatch) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    (line,) = err.strip().splitlines()
    assert line.startswith("depot: the database cannot be used"), line
    backend = url.split(":")[0].split("+")[0]
    assert f"DEPOT_DATABASE_URL names {backend}" in line and "not supported" in line, line
    assert "postgresql+psycopg://" in line and "SQLite" in line, line


@pytest.fixture(params=BACKENDS)
def unmigrated_url(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[str]:
    """An empty database of each backend: reachable, but never migrated."""
    if request.param == "sqlite":
        yield f"sqlite:///{tmp_path / 'empty.sqlite3'}"
        return
    if not POSTGRES_URL:
        pytest.skip("DEPOT_TEST_POSTGRES_URL is not set; PostgreSQL tests skipped")
    server, name = POSTGRES_URL.rsplit("/", 1)
    admin = make_engine(f"{server}/postgres").execution_options(isolation_level="AUTOCOMMIT")
    empty = f"{name}_unmigrated"
    with admin.connect() as connection:
        connection.execute(text(f'DROP DATABASE IF EXISTS "{empty}" WITH (FORCE)'))
        connection.execute(text(f'CREATE DATABASE "{empty}"'))
    yield f"{server}/{empty}"
    database.get_engine.cache_clear()
    with admin.connect() as connection:
        connection.execute(text(f'DROP DATABASE IF EXISTS "{empty}" WITH (FORCE)'))
    admin.dispose()


@pytest.mark.parametrize("command", [["user", "list"], ["replay"]])
def test_a_database_never_migrated_is_one_line_naming_depot_migrate(
    unmigrated_url: str,
    command: list[str],
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    """On an empty PostgreSQL database `depot user list` ended in a ProgrammingError
    traceback (SQLite's missing table is an OperationalError, which was already caught)."""
    assert _main_on_database(unmigrated_url, command, monkeypatch) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    (line,) = err.strip().splitlines()
    assert line.startswith("depot: the database is not migrated"), line
    assert "depot migrate" in line, line


def test_sections_shows_what_the_dispatcher_sees(
    cli_data_dir: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """`depot sections` (missing, found by the independent trial: no command showed the line's
    state): the demo day's alarm on AB in capitals, the same states as the API's answer."""
    assert main(["migrate"]) == 0
    assert main(["sections"]) == 0
    assert "no sections yet" in capsys.readouterr().out
    assert main(["demo"]) == 0
    capsys.readouterr()
    assert main(["sections"]) == 0
    lines = capsys.readouterr().out.splitlines()
    ab = next(line for line in lines if line.startswith("AB "))
    assert " ALARM " in ab and "incomplete" in ab, ab
    assert main(["sections", "--json"]) == 0
    shown = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    from service.app import create_app
    from tests.conftest import ADMIN

    with TestClient(create_app()) as client:
        api = client.get("/api/v1/sections", headers=ADMIN).json()
    assert shown == api
    assert len(lines) == len(api) + 1  # a heading, then one line per section
