"""The store's connection: the engine over SQLite in WAL mode or PostgreSQL, its
transactions, the schema brought up to date by the migrations, and whether the store
can take a job now (`unwritable`, `ping`). Jobs, batches and events build on it."""

from __future__ import annotations

import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Self

from sqlalchemy import Engine, create_engine, event, select, update
from sqlalchemy.engine import Connection
from sqlalchemy.exc import DBAPIError

from floorplan.service.migrations import upgrade
from floorplan.service.tables import jobs

#: What the database driver raises when the store cannot do what it is asked: a full
#: disk, a read-only file or server, a lost connection. The API answers it with 503.
StoreUnavailable = DBAPIError


class StoreBase:
    """The engine and its transactions, shared by the store's parts."""

    def __init__(self, url: str, *, migrate: bool = True, min_free_bytes: int = 0) -> None:
        self.engine: Engine = create_engine(url, pool_pre_ping=True)
        #: The SQLite file's directory, whose free space `unwritable` watches.
        self.directory: Path | None = None
        self.min_free_bytes = min_free_bytes
        if url.startswith("sqlite"):
            event.listen(self.engine, "connect", _sqlite_pragmas)
            if self.engine.url.database not in (None, "", ":memory:"):
                self.directory = Path(str(self.engine.url.database)).resolve().parent
        if migrate:
            upgrade(self.engine)

    @classmethod
    def sqlite(cls, path: Path) -> Self:
        path.parent.mkdir(parents=True, exist_ok=True)
        return cls(f"sqlite:///{path}")

    @contextmanager
    def _tx(self) -> Iterator[Connection]:
        with self.engine.begin() as conn:
            yield conn

    def unwritable(self) -> str | None:
        """Why the store cannot take a job now, or None when it can: a write is refused
        (a read-only file or mount, a read-only PostgreSQL), or the SQLite file's
        directory has less than `min_free_bytes` left (a job accepted there would be
        lost when its solve's writes fail)."""
        if self.directory is not None and self.min_free_bytes:
            try:
                free = shutil.disk_usage(self.directory).free
            except OSError as err:
                return f"its directory is not readable ({err.strerror})"
            if free < self.min_free_bytes:
                return (f"its disk has {free} bytes free, under the {self.min_free_bytes} "
                        "of FLOORPLAN_MIN_FREE_BYTES")
        try:  # a write that changes nothing: refused all the same by a read-only store
            with self._tx() as conn:
                conn.execute(update(jobs).where(jobs.c.id == _PROBE)
                             .values(updated_at=jobs.c.updated_at))
        except DBAPIError as err:
            return f"it refuses writes ({str(err.orig)[:200]})"
        return None

    def ping(self) -> bool:
        with self._tx() as conn:
            return conn.execute(select(1)).scalar() == 1


def _sqlite_pragmas(dbapi_connection: Any, _record: Any) -> None:
    cursor = dbapi_connection.cursor()
    cursor.execute("PRAGMA journal_mode=WAL")
    cursor.execute("PRAGMA synchronous=NORMAL")  # WAL keeps it durable across crashes
    cursor.execute("PRAGMA busy_timeout=5000")
    cursor.close()


#: No job has this id: `unwritable` writes to it, which changes nothing.
_PROBE = "-"
