"""The job store's schema history, as Alembic migrations (one schema for SQLite and
PostgreSQL). Every store brings itself to the newest revision when it opens; the
`alembic` command works too (`alembic upgrade head`, with FLOORPLAN_DATABASE_URL)."""

from __future__ import annotations

from pathlib import Path

from alembic import command
from alembic.config import Config
from sqlalchemy import Engine, inspect, text

#: The schema as it was before migrations existed (stores made by `create_all`).
FIRST_REVISION = "0001"
#: PostgreSQL advisory lock held while migrating: API nodes and workers starting at
#: once must not run the same migration twice.
MIGRATION_LOCK = 0x666C6F6F72


def alembic_config() -> Config:
    config = Config()
    config.set_main_option("script_location", str(Path(__file__).parent))
    return config


def upgrade(engine: Engine) -> None:
    """Bring the store's schema to the newest revision, in one transaction."""
    config = alembic_config()
    with engine.begin() as connection:
        if connection.dialect.name == "postgresql":
            connection.execute(text("SELECT pg_advisory_xact_lock(:key)"),
                               {"key": MIGRATION_LOCK})
        tables = set(inspect(connection).get_table_names())
        config.attributes["connection"] = connection
        if "jobs" in tables and "alembic_version" not in tables:
            command.stamp(config, FIRST_REVISION)  # an embedded store older than migrations
        command.upgrade(config, "head")
