"""A batch's brief stored once, in its row, not once per layout: the layouts' jobs made
from 0005 on leave their problem NULL and the store derives it from the batch's brief,
seed and limits (service.batch.layout_problem). Batches made before keep their jobs'
problems, so their brief columns are NULL.

Revision ID: 0005
Revises: 0004
Create Date: 2026-11-29
"""

from __future__ import annotations

import sqlalchemy as sa
from alembic import op

revision = "0005"
down_revision = "0004"
branch_labels = None
depends_on = None


def upgrade() -> None:
    with op.batch_alter_table("batches") as batch:
        batch.add_column(sa.Column("brief", sa.Text))
        batch.add_column(sa.Column("time_limit", sa.Float))
        batch.add_column(sa.Column("time_ceiling", sa.Float))
    with op.batch_alter_table("jobs") as batch:
        batch.alter_column("problem", existing_type=sa.Text, nullable=True)


def downgrade() -> None:
    # A batch's layouts get their problems back from its brief before the column goes:
    # the older code reads each job's own.
    from floorplan.service.batch import layout_problem

    conn = op.get_bind()
    rows = conn.execute(sa.text(
        "SELECT jobs.id, jobs.batch_index, batches.brief, batches.seed, "
        "batches.time_limit, batches.vary_program, batches.time_ceiling FROM jobs "
        "JOIN batches ON batches.id = jobs.batch_id WHERE jobs.problem IS NULL")).all()
    for row in rows:
        problem, time_limit = layout_problem(row.brief, row.seed + row.batch_index,
                                             row.time_limit, bool(row.vary_program),
                                             row.time_ceiling)
        conn.execute(sa.text("UPDATE jobs SET problem = :problem, time_limit = :limit "
                             "WHERE id = :id"),
                     {"problem": problem, "limit": time_limit, "id": row.id})
    with op.batch_alter_table("jobs") as batch:
        batch.alter_column("problem", existing_type=sa.Text, nullable=False)
    with op.batch_alter_table("batches") as batch:
        batch.drop_column("time_ceiling")
        batch.drop_column("time_limit")
        batch.drop_column("brief")
