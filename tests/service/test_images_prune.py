"""``depot images prune``: image files no event references go, once old enough; a referenced
image never goes, and neither does one an upload has just written or touched."""

from __future__ import annotations

import hashlib
import os
import threading
import time
from collections.abc import Iterator
from contextlib import AbstractContextManager
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import text

import ingest.service
import service.commands.images
from core import database
from core.database import make_engine
from core.settings import get_settings
from ingest.snapshots import check_image, image_store_lock, store_image, stored_image
from service.cli import main
from service.migrate import upgrade
from tests.conftest import BACKENDS, POSTGRES_URL
from tests.service.linekit import build_line
from tests.service.scratchdb import scratch_database
from tests.service.test_service_snapshots import encoded, upload

HOURS_AGO = 2 * 3600
_CACHES = (get_settings, database.get_engine, database.get_sessionmaker)


@pytest.fixture(scope="module", params=BACKENDS)
def database_url(
    request: pytest.FixtureRequest, tmp_path_factory: pytest.TempPathFactory
) -> Iterator[str]:
    """A migrated database for this file's tests, on each backend (emptied after each test)."""
    if request.param == "sqlite":
        url = f"sqlite:///{tmp_path_factory.mktemp('prune') / 'depot.sqlite3'}"
        upgrade(url)
        yield url
        return
    if not POSTGRES_URL:
        pytest.skip("DEPOT_TEST_POSTGRES_URL is not set; PostgreSQL tests skipped")
    with scratch_database("prune") as url:
        upgrade(url)
        yield url


@pytest.fixture
def image_dir(database_url: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Iterator[Path]:
    """The CLI and the app on ``database_url``, with an image store of this test's own."""
    monkeypatch.setenv("DEPOT_DATA_DIR", str(tmp_path))
    monkeypatch.setenv("DEPOT_DATABASE_URL", database_url)
    for cache in _CACHES:
        cache.cache_clear()
    yield get_settings().image_dir
    database.get_engine().dispose()
    for cache in _CACHES:
        cache.cache_clear()
    from service.models import metadata

    engine = make_engine(database_url)
    with engine.begin() as connection:
        for table in reversed(metadata.sorted_tables):
            connection.execute(table.delete())
    engine.dispose()


@pytest.fixture
def client(image_dir: Path) -> Iterator[TestClient]:
    from service.app import create_app

    with TestClient(create_app()) as test_client:
        yield test_client


def image(n: int) -> bytes:
    """A JPEG of its own for each ``n``."""
    return encoded(".jpg", width=320 + n)


def path_of(image_dir: Path, data: bytes) -> Path:
    return stored_image(image_dir, hashlib.sha256(data).hexdigest(), "image/jpeg")


def orphan(image_dir: Path, data: bytes, *, age_s: float = HOURS_AGO) -> Path:
    """An image stored as an upload stores it, whose event never committed, ``age_s`` old."""
    checked = check_image(data, max_bytes=10**8, max_pixels=10**8)
    return aged(store_image(image_dir, checked, data), age_s)


def aged(path: Path, age_s: float) -> Path:
    then = time.time() - age_s
    os.utime(path, (then, then))
    return path


def prune(capsys: pytest.CaptureFixture[str], *args: str) -> list[str]:
    assert main(["images", "prune", *args]) == 0
    return capsys.readouterr().out.splitlines()


def test_the_409_losers_image_goes_and_the_accepted_one_stays(
    client: TestClient,
    image_dir: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The problem: two uploads of one event_id with different images, at once; the second
    is refused (409) but its image was already written. Both old: only the refused one's
    file goes."""
    keys = build_line(client)
    accepted, refused = image(1), image(2)
    assert getattr(upload(client, keys["B-cam"], accepted), "status_code", None) == 201
    # The race: the second upload asked whether its event_id was used before the first
    # had committed, so it wrote its image and was refused only by the insert.
    monkeypatch.setattr(ingest.service, "answer_if_stored", lambda *args: None)
    assert getattr(upload(client, keys["B-cam"], refused), "status_code", None) == 409
    kept, lost = aged(path_of(image_dir, accepted), HOURS_AGO), path_of(image_dir, refused)
    aged(lost, HOURS_AGO)
    size = lost.stat().st_size
    out = prune(capsys)
    assert kept.exists() and not lost.exists()
    assert out[0].startswith("removed 1 unreferenced image and 0 stale temporary files,"), out
    assert f" {size} bytes" in out[0], out
    assert out[1].startswith("kept 1 referenced image; kept 0 too recent"), out
    assert out[2].startswith("left alone 0 other entries"), out


def test_an_image_only_its_raw_event_names_is_kept(
    client: TestClient, image_dir: Path, capsys: pytest.CaptureFixture[str], database_url: str
) -> None:
    """The raw events are the source of truth (`depot replay` rebuilds the snapshots from
    them): an image whose snapshot row is gone is still referenced."""
    keys = build_line(client)
    data = image(3)
    assert getattr(upload(client, keys["B-cam"], data), "status_code", None) == 201
    engine = make_engine(database_url)
    with engine.begin() as connection:
        assert connection.execute(text("DELETE FROM snapshots")).rowcount == 1
    engine.dispose()
    path = aged(path_of(image_dir, data), HOURS_AGO)
    out = prune(capsys, "--older-than", "600")
    assert path.exists()
    assert out[1].startswith("kept 1 referenced image;"), out


def test_a_recent_orphan_is_kept(image_dir: Path, capsys: pytest.CaptureFixture[str]) -> None:
    young = orphan(image_dir, image(4), age_s=3000)  # younger than the default hour
    old = orphan(image_dir, image(5))
    out = prune(capsys)
    assert young.exists() and not old.exists()
    assert "kept 1 too recent (changed within the last 3600 s)" in out[1], out
    out = prune(capsys, "--older-than", "1800")
    assert not young.exists()
    assert out[0].startswith("removed 1 unreferenced image"), out


def test_a_dry_run_removes_nothing_and_says_what_it_would(
    image_dir: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    old = orphan(image_dir, image(6))
    stale = old.parent / "tmpabc123.tmp"
    stale.write_bytes(b"partial")
    aged(stale, HOURS_AGO)
    size = old.stat().st_size + stale.stat().st_size
    out = prune(capsys, "--dry-run")
    assert old.exists() and stale.exists()
    assert out[0].startswith("would remove (dry run) 1 unreferenced image and 1 stale"), out
    assert f" {size} bytes" in out[0], out
    out = prune(capsys)
    assert not old.exists() and not stale.exists()
    assert out[0].startswith("removed 1 unreferenced image and 1 stale temporary file,"), out


@pytest.mark.parametrize("seconds", ["0", "599", "-3600", "599.9"])
def test_a_cutoff_under_ten_minutes_is_refused(
    image_dir: Path, seconds: str, capsys: pytest.CaptureFixture[str]
) -> None:
    old = orphan(image_dir, image(7))
    assert main(["images", "prune", "--older-than", seconds]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert line.startswith(f"depot: --older-than {float(seconds):g} is too short"), line
    assert "at least 600 seconds" in line and "before its event commits" in line, line
    assert old.exists()


@pytest.mark.parametrize("seconds", ["nan", "inf", "an hour"])
def test_a_cutoff_that_is_no_number_is_refused(
    image_dir: Path, seconds: str, capsys: pytest.CaptureFixture[str]
) -> None:
    with pytest.raises(SystemExit) as done:
        main(["images", "prune", "--older-than", seconds])
    assert done.value.code == 2
    assert capsys.readouterr().err.startswith("depot: images prune: argument --older-than")


def test_a_reupload_of_an_orphans_bytes_makes_it_recent(
    image_dir: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """An upload of the same bytes as an old orphan, between its write and its commit: the
    write found the file there and refreshed its mtime, so the prune keeps it."""
    data = image(8)
    path = orphan(image_dir, data)
    before = path.stat().st_mtime
    checked = check_image(data, max_bytes=10**8, max_pixels=10**8)
    assert store_image(image_dir, checked, data) == path  # the new upload, not yet committed
    assert path.stat().st_mtime > before + HOURS_AGO - 60
    out = prune(capsys)
    assert path.exists()
    assert "kept 1 too recent" in out[1], out


def test_a_file_touched_while_the_prune_waits_for_the_lock_is_kept(
    image_dir: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """The prune looks at a file's mtime again under the exclusive lock, right before
    removing it: an upload that held the shared lock and touched the file meanwhile wins."""
    path = orphan(image_dir, image(9))
    asking = threading.Event()

    def announced(folder: Path, *, exclusive: bool) -> AbstractContextManager[None]:
        asking.set()
        return image_store_lock(folder, exclusive=exclusive)

    monkeypatch.setattr(service.commands.images, "image_store_lock", announced)
    codes: list[int] = []
    with image_store_lock(image_dir, exclusive=False):
        sweeper = threading.Thread(target=lambda: codes.append(main(["images", "prune"])))
        sweeper.start()
        assert asking.wait(timeout=30), "the prune never asked for the lock"
        time.sleep(0.3)
        assert sweeper.is_alive() and path.exists(), "the prune must wait for the shared lock"
        os.utime(path)  # what store_image does under the shared lock
    sweeper.join(timeout=30)
    assert codes == [0] and path.exists()
    assert "kept 1 too recent" in capsys.readouterr().out


def test_stale_temporary_files_go_and_a_write_in_progress_stays(
    image_dir: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A process killed while writing leaves ``tmp….tmp`` (``tempfile.mkstemp``) behind."""
    shard = image_dir / "ab"
    shard.mkdir(parents=True)
    stale, writing = shard / "tmpk1ll3d_.tmp", shard / "tmpwr1t1ng.tmp"
    stale.write_bytes(b"\xff\xd8 half a JPEG")
    writing.write_bytes(b"\xff\xd8 being written")
    aged(stale, HOURS_AGO)
    out = prune(capsys)
    assert not stale.exists() and writing.exists()
    assert out[0].startswith("removed 0 unreferenced images and 1 stale temporary file,"), out
    assert "kept 1 too recent" in out[1], out


def test_files_it_does_not_recognise_are_left_alone(
    image_dir: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Only ``<sha[:2]>/<sha256>.jpg|.png`` and ``.tmp`` files are the store's: anything
    else (an operator's notes, another suffix, capitals, the wrong folder, a link) stays,
    however old, and is counted."""
    real = orphan(image_dir, image(10))
    sha = real.stem
    foreign = [
        image_dir / "README.txt",
        image_dir / f"{sha}.jpg",  # not in its <sha[:2]> folder
        real.parent / f"{sha}.gif",
        real.parent / f"{sha.upper()}.jpg",
        real.parent / f"{sha[:-1]}.jpg",
        image_dir / "zz" / f"{sha}.jpg",
        image_dir / "backup" / "0a" / "old.tmp",
    ]
    for path in foreign:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(b"not ours")
        aged(path, HOURS_AGO)
    wrong_shard = image_dir / "00" / f"{'1' * 64}.jpg"
    wrong_shard.parent.mkdir(exist_ok=True)
    wrong_shard.write_bytes(b"named for another folder")
    aged(wrong_shard, HOURS_AGO)
    link = real.parent / f"{'a' * 64}.png"
    link.symlink_to(real)
    out = prune(capsys)
    assert all(path.exists() for path in [*foreign, wrong_shard]) and link.is_symlink()
    assert not real.exists()
    # README, the misplaced image, zz/, backup/ at the top; .gif, capitals, short name, the
    # other folder's name and the link inside the shards
    assert out[2].startswith("left alone 9 other entries"), out
    assert out[0].startswith("removed 1 unreferenced image"), out


def test_no_image_store_yet_is_nothing_to_do(
    image_dir: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert not image_dir.exists()
    out = prune(capsys)
    assert out[0].startswith("removed 0 unreferenced images and 0 stale temporary files"), out
