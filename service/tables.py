"""The job store's tables (SQLAlchemy Core), one schema for SQLite and PostgreSQL: what
service/store/ reads and writes and what the Alembic migrations (service/migrations)
are checked against."""

from sqlalchemy import (
    Boolean,
    Column,
    Float,
    Index,
    Integer,
    MetaData,
    String,
    Table,
    Text,
)

metadata = MetaData()

jobs = Table(
    "jobs", metadata,
    Column("id", String(36), primary_key=True),
    Column("owner", String(64), nullable=False, default=""),
    Column("status", String(16), nullable=False, index=True),
    Column("termination", String(32)),
    # NULL for a layout of a batch made since migration 0005: its problem is derived
    # from the batch's brief (batches.brief), stored once for all its layouts.
    Column("problem", Text),
    Column("time_limit", Float, nullable=False),
    Column("result", Text),
    Column("incumbent", Text),
    Column("progress", Text),
    Column("error", Text),
    Column("idempotency_key", String(200)),
    Column("body_hash", String(64)),
    Column("attempts", Integer, nullable=False, default=0),
    Column("cancel_requested", Boolean, nullable=False, default=False),
    Column("created_at", Float, nullable=False, index=True),
    Column("started_at", Float),
    Column("finished_at", Float),
    Column("updated_at", Float, nullable=False),
    # The distributed mode: who holds the job, when it last said so, when it was sent to
    # the broker (NULL: not yet, or the broker lost it).
    Column("worker", String(200)),
    Column("heartbeat_at", Float),
    Column("dispatched_at", Float),
    # A job that is one layout of a batch, and its place in the batch (its seed is the
    # batch's seed plus this).
    Column("batch_id", String(36), index=True),
    Column("batch_index", Integer),
    # A retried POST finds the job its Idempotency-Key made; concurrent ones that all
    # found none cannot each make one (migration 0003).
    Index("ux_jobs_owner_idempotency_key", "owner", "idempotency_key", unique=True),
)

events = Table(
    "events", metadata,
    Column("job_id", String(36), primary_key=True),
    Column("seq", Integer, primary_key=True),
    Column("kind", String(16), nullable=False),
    Column("data", Text, nullable=False),
    Column("created_at", Float, nullable=False),
)

# A batch is ordinary jobs (jobs.batch_id), made in one transaction with it.
batches = Table(
    "batches", metadata,
    Column("id", String(36), primary_key=True),
    Column("owner", String(64), nullable=False, default=""),
    Column("name", String(200), nullable=False),
    Column("count", Integer, nullable=False),
    Column("seed", Integer, nullable=False),
    Column("vary_program", Boolean, nullable=False, default=False),
    Column("created_at", Float, nullable=False, index=True),
    # The brief (JSON as sent), the per-layout limit the request gave and the service's
    # FLOORPLAN_MAX_TIME_LIMIT then: what each layout's problem is derived from
    # (service.batch.layout_problem). NULL for a batch made before migration 0005,
    # whose jobs hold their problems.
    Column("brief", Text),
    Column("time_limit", Float),
    Column("time_ceiling", Float),
)
