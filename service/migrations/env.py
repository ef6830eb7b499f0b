"""Alembic's entry point: migrate the connection the store hands over, or, from the
`alembic` command line, the database of FLOORPLAN_DATABASE_URL (else the SQLite store)."""

from __future__ import annotations

from alembic import context
from sqlalchemy import Connection, create_engine

from floorplan.service.tables import metadata


def _migrate(connection: Connection) -> None:
    context.configure(
        connection=connection, target_metadata=metadata,
        # SQLite alters tables by copying them; Alembic's batch mode does that.
        render_as_batch=connection.dialect.name == "sqlite",
    )
    with context.begin_transaction():
        context.run_migrations()


def _store_url() -> str:
    from floorplan.service.settings import Settings

    return Settings().store_url


if context.is_offline_mode():  # `alembic upgrade head --sql`: print the SQL
    context.configure(url=_store_url(), target_metadata=metadata, literal_binds=True)
    with context.begin_transaction():
        context.run_migrations()
elif (given := context.config.attributes.get("connection")) is not None:
    _migrate(given)
else:
    with create_engine(_store_url()).begin() as own:
        _migrate(own)
