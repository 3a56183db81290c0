"""Backup and restore (docs/OPERATIONS.md): deploy/restore-test.sh backs up a PostgreSQL
database with its image store, restores both elsewhere and compares every row and image."""

from __future__ import annotations

import os
import shutil
import subprocess
from collections.abc import Iterator
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import create_engine, text

from core.database import make_engine
from core.settings import get_settings
from service.migrate import upgrade
from tests.conftest import ADMIN, POSTGRES_URL, app_on
from tests.service.linekit import build_line, event
from tests.service.scratchdb import drop, scratch_database, scratch_name
from tests.service.test_service_snapshots import encoded, upload

DEPLOY = Path(__file__).resolve().parents[2] / "deploy"
pytestmark = pytest.mark.skipif(
    not POSTGRES_URL or shutil.which("pg_dump") is None,
    reason="needs DEPOT_TEST_POSTGRES_URL and the PostgreSQL client tools",
)


@pytest.fixture
def source(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[dict[str, str]]:
    """A migrated database with a line, events, a person and a snapshot image; the
    restore test's target named too (both this run's own: tests/service/scratchdb.py)."""
    target = scratch_name("backup_dst")
    with scratch_database("backup_src") as url:
        upgrade(url)
        monkeypatch.setenv("DEPOT_DATA_DIR", str(tmp_path / "data"))
        get_settings.cache_clear()
        engine = make_engine(url)
        with TestClient(app_on(engine)) as client:
            keys = build_line(client)
            body = event("bk-ac-1", "axle_count", section="AB", axles=16)
            posted = client.post("/api/v1/events", json=body, headers=keys["A-ac"])
            assert posted.status_code == 201
            shot = upload(client, keys["A-cam"], encoded(".jpg"), event_id="bk-cam-1")
            assert getattr(shot, "status_code", None) == 201
            person = {"name": "olena", "role": "dispatcher"}
            assert client.post("/api/v1/users", json=person, headers=ADMIN).status_code == 201
        engine.dispose()
        get_settings.cache_clear()
        try:
            yield {
                **os.environ,
                "DEPOT_DATABASE_URL": url,
                "DEPOT_DATA_DIR": str(tmp_path / "data"),
                "DEPOT_RESTORE_TEST_DB": target,
            }
        finally:
            drop(target)


def test_a_backup_restores_every_row_and_image(source: dict[str, str]) -> None:
    done = subprocess.run(
        [DEPLOY / "restore-test.sh"], env=source, capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 0, done.stderr
    summary = done.stdout.strip().splitlines()[-1]
    assert summary.startswith("restore verified:"), done.stdout
    images = int(summary.split(" images")[0].rsplit(" ", 1)[-1])
    assert images == 1
    assert int(summary.split(" rows")[0].rsplit(" ", 1)[-1]) > 20


def test_a_damaged_backup_is_refused(source: dict[str, str], tmp_path: Path) -> None:
    made = subprocess.run(
        [DEPLOY / "backup.sh", tmp_path / "backups"], env=source, capture_output=True, text=True
    )
    assert made.returncode == 0, made.stderr
    backup = Path(made.stdout.strip())
    with (backup / "images.tar").open("r+b") as archive:
        archive.seek(600)
        archive.write(b"\xff" * 16)
    target = {**source, "DEPOT_DATA_DIR": str(tmp_path / "restored")}
    refused = subprocess.run(
        [DEPLOY / "restore.sh", backup], env=target, capture_output=True, text=True
    )
    assert refused.returncode == 2
    assert "fails its checksums" in refused.stderr
    assert not (tmp_path / "restored").exists()  # nothing was half-restored


def test_the_restore_test_never_drops_the_database_it_checks(source: dict[str, str]) -> None:
    """With DEPOT_RESTORE_TEST_DB naming the source, the script dropped the live database and
    called an empty result verified (found by the independent trial)."""
    checked = source["DEPOT_DATABASE_URL"].rsplit("/", 1)[1]
    same = {**source, "DEPOT_RESTORE_TEST_DB": checked}
    done = subprocess.run(
        [DEPLOY / "restore-test.sh"], env=same, capture_output=True, text=True, timeout=300
    )
    assert done.returncode == 2 and "is the database being checked" in done.stderr, done.stderr
    admin = create_engine(source["DEPOT_DATABASE_URL"])
    with admin.connect() as connection:  # the source is still there, rows and all
        assert connection.execute(text("SELECT count(*) FROM raw_events")).scalar_one() > 0
    admin.dispose()


def test_a_backup_whose_checksums_leave_a_part_out_is_refused(
    source: dict[str, str], tmp_path: Path
) -> None:
    """SHA256SUMS listing only the dump let a truncated images.tar through (second trial)."""
    made = subprocess.run(
        [DEPLOY / "backup.sh", tmp_path / "backups"], env=source, capture_output=True, text=True
    )
    backup = Path(made.stdout.strip())
    sums = backup / "SHA256SUMS"
    sums.write_text("".join(x for x in sums.read_text().splitlines(True) if "database" in x))
    with (backup / "images.tar").open("r+b") as archive:
        archive.truncate(100)
    target = {**source, "DEPOT_DATA_DIR": str(tmp_path / "restored")}
    refused = subprocess.run(
        [DEPLOY / "restore.sh", backup], env=target, capture_output=True, text=True
    )
    assert refused.returncode == 2 and "does not list images.tar" in refused.stderr
    assert not (tmp_path / "restored").exists()


def test_a_backup_is_readable_by_its_owner_only(source: dict[str, str], tmp_path: Path) -> None:
    """The dump holds every person's token hash and every device's key hash: it was written
    0644 under a 0755 folder (found by the independent trial). Files 0600, folders 0700,
    whatever the caller's umask."""
    made = subprocess.run(
        ["sh", "-c", 'umask 022; exec "$0" "$1"', DEPLOY / "backup.sh", tmp_path / "backups"],
        env=source, capture_output=True, text=True,
    )  # fmt: skip
    assert made.returncode == 0, made.stderr
    backup = Path(made.stdout.strip())
    for folder in (tmp_path / "backups", backup):
        assert folder.stat().st_mode & 0o777 == 0o700, (folder, oct(folder.stat().st_mode))
    for part in ("database.dump", "images.tar", "SHA256SUMS"):
        mode = (backup / part).stat().st_mode & 0o777
        assert mode == 0o600, (part, oct(mode))


def test_the_databases_are_this_runs_own(source: dict[str, str]) -> None:
    """Fixed names (depot_ops_backup_src/dst) made two runs on one server drop each other's
    databases: the names derive from DEPOT_TEST_POSTGRES_URL's database and a uuid."""
    assert POSTGRES_URL
    own = POSTGRES_URL.rsplit("/", 1)[1] + "_"
    src = source["DEPOT_DATABASE_URL"].rsplit("/", 1)[1]
    dst = source["DEPOT_RESTORE_TEST_DB"]
    assert src.startswith(own) and dst.startswith(own) and src != dst, (src, dst)
