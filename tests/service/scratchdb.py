"""Scratch PostgreSQL databases for tests that need a database of their own (backups,
migrations): named after the run's test database (DEPOT_TEST_POSTGRES_URL) and a uuid, so two
runs in parallel — two helpers, two CI jobs on one server — never drop each other's."""

from __future__ import annotations

import uuid
from collections.abc import Iterator
from contextlib import contextmanager

import sqlalchemy as sa

from tests.conftest import POSTGRES_URL

# PostgreSQL cuts identifiers at 63 bytes: a longer name would silently be another one.
_MAX_NAME = 63


def server_url() -> str:
    """The test server's URL without a database."""
    assert POSTGRES_URL, "DEPOT_TEST_POSTGRES_URL is not set"
    return POSTGRES_URL.rsplit("/", 1)[0]


def scratch_name(tag: str) -> str:
    """``<test database>_<tag>_<8 hex>``: this run's own name."""
    assert POSTGRES_URL, "DEPOT_TEST_POSTGRES_URL is not set"
    name = f"{POSTGRES_URL.rsplit('/', 1)[1]}_{tag}_{uuid.uuid4().hex[:8]}"
    assert len(name) <= _MAX_NAME, name
    return name


def drop(name: str) -> None:
    admin = sa.create_engine(f"{server_url()}/postgres", isolation_level="AUTOCOMMIT")
    with admin.connect() as connection:
        connection.execute(sa.text(f'DROP DATABASE IF EXISTS "{name}" WITH (FORCE)'))
    admin.dispose()


@contextmanager
def scratch_database(tag: str) -> Iterator[str]:
    """A new empty database (its URL), dropped afterwards."""
    name = scratch_name(tag)
    admin = sa.create_engine(f"{server_url()}/postgres", isolation_level="AUTOCOMMIT")
    with admin.connect() as connection:
        connection.execute(sa.text(f'CREATE DATABASE "{name}"'))
    admin.dispose()
    try:
        yield f"{server_url()}/{name}"
    finally:
        drop(name)
