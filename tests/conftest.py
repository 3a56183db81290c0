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
POSTGRES_URL = os.environ.get("DEPOT_TEST_POSTGRES_URL")
BACKENDS = ["sqlite", pytest.param("postgresql", marks=pytest.mark.postgresql)]


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


def _fresh_postgres(url: str) -> None:
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
