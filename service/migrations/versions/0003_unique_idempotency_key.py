"""One job per owner and Idempotency-Key, enforced by the database: concurrent POSTs
with one key each saw no job yet and each inserted one.

Jobs already duplicated keep their key on the oldest only (the one a replay found
first); the others stay, without a key, so that the index can be built.

Revision ID: 0003
Revises: 0002
Create Date: 2026-11-25
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0003"
down_revision = "0002"
branch_labels = None
depends_on = None

INDEX = "ux_jobs_owner_idempotency_key"


def upgrade() -> None:
    op.execute(sa.text(
        "UPDATE jobs SET idempotency_key = NULL WHERE idempotency_key IS NOT NULL AND EXISTS ("
        "SELECT 1 FROM jobs AS older WHERE older.owner = jobs.owner"
        " AND older.idempotency_key = jobs.idempotency_key"
        " AND (older.created_at < jobs.created_at"
        " OR (older.created_at = jobs.created_at AND older.id < jobs.id)))"
    ))
    # NULL keys (jobs posted without one) never collide, on SQLite and PostgreSQL alike.
    op.create_index(INDEX, "jobs", ["owner", "idempotency_key"], unique=True)


def downgrade() -> None:
    op.drop_index(INDEX, "jobs")
