"""The store's connection: the engine over SQLite in WAL mode or PostgreSQL, its
transactions, the schema brought up to date by the migrations, and whether the store
can take a job now (`unwritable`, `ping`). Jobs, batches and events build on it."""

from __future__ import annotations

import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Self

from sqlalchemy import (
    Engine,
    LargeBinary,
    cast,
    create_engine,
    event,
    func,
    select,
    text,
    update,
)
from sqlalchemy.engine import Connection
from sqlalchemy.exc import DBAPIError

from floorplan.models.jobs import JobStatus
from floorplan.service.migrations import upgrade
from floorplan.service.tables import batches, jobs

#: What the database driver raises when the store cannot do what it is asked: a full
#: disk, a read-only file or server, a lost connection. The API answers it with 503.
StoreUnavailable = DBAPIError


@dataclass(frozen=True)
class Quota:
    """The limits new jobs are admitted within: `per_key` queued and running jobs of one
    owner (FLOORPLAN_MAX_JOBS_PER_KEY), `queue` queued jobs in all (FLOORPLAN_QUEUE_LIMIT)."""

    per_key: int
    queue: int
    #: Bytes one owner's jobs may keep in the store (FLOORPLAN_MAX_STORED_BYTES_PER_KEY):
    #: problems, results and incumbents, of every job not yet deleted.
    stored_bytes: int | None = None


class QuotaExceeded(Exception):
    """Admitting the jobs would take `what` ("key", "queue" or "bytes") to `count`, over
    `limit`."""

    def __init__(self, what: str, count: int, limit: int) -> None:
        super().__init__(f"{what}: {count} over {limit}")
        self.what, self.count, self.limit = what, count, limit


#: The PostgreSQL advisory lock every admission takes (an arbitrary 64-bit number).
ADMISSION_LOCK = 0x666C6F6F72706C61


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

    @contextmanager
    def _admission(self) -> Iterator[Connection]:
        """A transaction that admits new jobs, one such transaction at a time, so that
        the counts `_within` reads stay true until its inserts commit: four concurrent
        batches of 300 cannot each find the key's 400 free. The queue limit is every
        key's, so admissions are serialized across keys, not per key; each is one short
        transaction. SQLite: BEGIN IMMEDIATE takes the write lock before the counts are
        read (a deferred transaction would read, then fail to write). PostgreSQL: a
        transaction-scoped advisory lock, released by the commit."""
        if self.engine.dialect.name == "sqlite":
            with self.engine.connect() as conn:
                conn.exec_driver_sql("BEGIN IMMEDIATE")
                try:
                    yield conn
                except BaseException:
                    conn.rollback()
                    raise
                conn.commit()
        else:
            with self.engine.begin() as conn:
                conn.execute(text("SELECT pg_advisory_xact_lock(:lock)"),
                             {"lock": ADMISSION_LOCK})
                yield conn

    def _within(self, conn: Connection, owner: str, adding: int, quota: Quota,
                adding_bytes: int = 0) -> None:
        """Raise QuotaExceeded when `adding` more queued jobs of `owner` (their problems
        `adding_bytes` long) go past `quota`, counted in the admitting transaction
        (`_admission`)."""
        mine = int(conn.execute(select(func.count()).select_from(jobs).where(
            jobs.c.owner == owner,
            jobs.c.status.in_([JobStatus.QUEUED, JobStatus.RUNNING]))).scalar_one())
        if mine + adding > quota.per_key:
            raise QuotaExceeded("key", mine + adding, quota.per_key)
        queued = int(conn.execute(select(func.count()).select_from(jobs).where(
            jobs.c.status == JobStatus.QUEUED)).scalar_one())
        if queued + adding > quota.queue:
            raise QuotaExceeded("queue", queued + adding, quota.queue)
        if quota.stored_bytes is not None:
            stored = self._stored_bytes(conn, owner) + adding_bytes
            if stored > quota.stored_bytes:
                raise QuotaExceeded("bytes", stored, quota.stored_bytes)

    def _stored_bytes(self, conn: Connection, owner: str) -> int:
        """The bytes `owner`'s jobs keep: problems, results and incumbents, finished and
        canceled jobs too until they are deleted, and the briefs of its batches (each
        once, whatever its count; a batch goes with its last job)."""
        def size(column: Any) -> Any:
            if self.engine.dialect.name == "sqlite":  # its length() counts characters
                return func.coalesce(func.length(cast(column, LargeBinary)), 0)
            return func.coalesce(func.octet_length(column), 0)

        total = select(func.coalesce(func.sum(
            size(jobs.c.problem) + size(jobs.c.result) + size(jobs.c.incumbent)), 0)
        ).where(jobs.c.owner == owner)
        briefs = select(func.coalesce(func.sum(size(batches.c.brief)), 0)).where(
            batches.c.owner == owner)
        return int(conn.execute(total).scalar_one()) + int(conn.execute(briefs).scalar_one())

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
