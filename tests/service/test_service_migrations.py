"""Alembic owns the schema: the migrations build exactly the models, and undo cleanly."""

from __future__ import annotations

from pathlib import Path

from alembic import command
from alembic.autogenerate import compare_metadata
from alembic.runtime.migration import MigrationContext
from sqlalchemy import create_engine, inspect

from service.migrate import alembic_config, head_revision, upgrade
from service.models import metadata


def test_migrations_match_models_and_downgrade(tmp_path: Path) -> None:
    url = f"sqlite:///{tmp_path / 'm.sqlite3'}"
    upgrade(url)
    engine = create_engine(url)
    with engine.connect() as connection:
        context = MigrationContext.configure(connection)
        assert context.get_current_revision() == head_revision()
        assert compare_metadata(context, metadata) == []
    command.downgrade(alembic_config(url), "base")
    assert set(inspect(engine).get_table_names()) <= {"alembic_version"}
    engine.dispose()


def test_constraints_follow_the_naming_convention() -> None:
    names = {c.name for table in metadata.sorted_tables for c in table.constraints}
    assert "pk_raw_events" in names and "uq_raw_events_device_id_event_id" in names
    assert all(name and not name.startswith("sqlite_") for name in names)
