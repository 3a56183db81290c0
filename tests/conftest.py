"""Shared fixtures: a migrated database per backend (SQLite always, PostgreSQL when its URL is
given), a session whose every test rolls back, and an HTTP client on the real app."""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import Engine, text
from sqlalchemy.orm import Session, sessionmaker

from core.database import get_session, make_engine
from core.settings import get_settings
from service.migrate import upgrade

ADMIN_TOKEN = "test-admin-token-0123456789abcdef"
# Under pytest-xdist (``make test`` runs two workers) each worker has its own database,
# ``<DEPOT_TEST_POSTGRES_URL's database>_gw<n>``: the schema is dropped and migrated per worker.
_WORKER = os.environ.get("PYTEST_XDIST_WORKER")
_GIVEN_URL = os.environ.get("DEPOT_TEST_POSTGRES_URL")
POSTGRES_URL = f"{_GIVEN_URL}_{_WORKER}" if _GIVEN_URL and _WORKER else _GIVEN_URL
BACKENDS = ["sqlite", pytest.param("postgresql", marks=pytest.mark.postgresql)]
# Test packages whose tests share one line in file order (a package-scoped fixture): one worker.
_ONE_WORKER_PACKAGES = ("transports",)


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """With ``--dist loadgroup`` a file's tests stay on one worker (its module fixtures are
    built once) and so does each package in ``_ONE_WORKER_PACKAGES``."""
    if not config.pluginmanager.hasplugin("xdist"):
        return
    for item in items:
        relative = Path(str(item.path)).relative_to(Path(__file__).parent)
        group = relative.parts[0] if relative.parts[0] in _ONE_WORKER_PACKAGES else str(relative)
        item.add_marker(pytest.mark.xdist_group(group))


@pytest.fixture(scope="session")
def data_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("depot-data")


@pytest.fixture(scope="session", autouse=True)
def _settings(data_dir: Path) -> Iterator[None]:
    os.environ["DEPOT_DATA_DIR"] = str(data_dir)
    os.environ["DEPOT_ADMIN_TOKEN"] = ADMIN_TOKEN
    os.environ["DEPOT_ENVIRONMENT"] = "test"
    get_settings.cache_clear()
    yield
    get_settings.cache_clear()


def _worker_database(url: str, *, drop: bool = False) -> None:
    """Create (or drop) this xdist worker's own database on the server of ``url``."""
    server, name = url.rsplit("/", 1)
    admin = make_engine(f"{server}/postgres").execution_options(isolation_level="AUTOCOMMIT")
    with admin.connect() as connection:
        if drop:
            connection.execute(text(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'))
        elif not connection.scalar(
            text("SELECT 1 FROM pg_database WHERE datname = :name"), {"name": name}
        ):
            connection.execute(text(f'CREATE DATABASE "{name}"'))
    admin.dispose()


def _fresh_postgres(url: str) -> None:
    if _WORKER:
        _worker_database(url)
    engine = make_engine(url)
    with engine.begin() as connection:
        connection.execute(text("DROP SCHEMA public CASCADE"))
        connection.execute(text("CREATE SCHEMA public"))
    engine.dispose()


@pytest.fixture(scope="session", params=BACKENDS)
def engine(request: pytest.FixtureRequest, data_dir: Path) -> Iterator[Engine]:
    """A database built only by the migrations."""
    if request.param == "postgresql":
        if not POSTGRES_URL:
            pytest.skip("DEPOT_TEST_POSTGRES_URL is not set; PostgreSQL tests skipped")
        url = POSTGRES_URL
        _fresh_postgres(url)
    else:
        url = f"sqlite:///{data_dir / 'test.sqlite3'}"
    upgrade(url)
    engine = make_engine(url)
    yield engine
    engine.dispose()
    if request.param == "postgresql" and _WORKER:
        _worker_database(url, drop=True)


@pytest.fixture
def session(engine: Engine) -> Iterator[Session]:
    """A session inside an outer transaction that is rolled back after the test."""
    connection = engine.connect()
    outer = connection.begin()
    db = Session(bind=connection, join_transaction_mode="create_savepoint", expire_on_commit=False)
    try:
        yield db
    finally:
        db.close()
        outer.rollback()
        connection.close()


@pytest.fixture
def app(session: Session) -> Any:
    from service.app import create_app

    application = create_app()

    def _test_session() -> Iterator[Session]:
        try:
            yield session
            session.commit()
        except BaseException:
            session.rollback()
            raise

    application.dependency_overrides[get_session] = _test_session
    return application


@pytest.fixture
def client(app: Any) -> Iterator[TestClient]:
    with TestClient(app) as test_client:
        yield test_client


ADMIN = {"Authorization": f"Bearer {ADMIN_TOKEN}"}


def app_on(engine: Engine) -> Any:
    """The app with real, committing request sessions on ``engine`` (no per-test rollback)."""
    from service.app import create_app

    factory = sessionmaker(bind=engine, expire_on_commit=False)
    application = create_app()

    def _real_session() -> Iterator[Session]:
        db = factory()
        try:
            yield db
            db.commit()
        except BaseException:
            db.rollback()
            raise
        finally:
            db.close()

    application.dependency_overrides[get_session] = _real_session
    return application


@pytest.fixture
def committed_app(engine: Engine) -> Iterator[Any]:
    """The app with real, committing sessions (for concurrency tests); tables emptied after."""
    from service.models import metadata

    application = app_on(engine)
    yield application
    with engine.begin() as connection:
        for table in reversed(metadata.sorted_tables):
            connection.execute(table.delete())
