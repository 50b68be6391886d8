"""Large texts and JSON stored once, compressed, by content hash: plan versions reference their
PDDL (the domain text is the same for every version) and steps, replans their old and new
plans, trajectories their points.

Revision ID: 0002
Revises: 0001
"""

import sqlalchemy as sa
from alembic import op

revision = "0002"
down_revision = "0001"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "blobs",
        sa.Column("sha256", sa.String(64), primary_key=True),
        sa.Column("codec", sa.String(8), nullable=False),
        sa.Column("size", sa.Integer, nullable=False),
        sa.Column("data", sa.LargeBinary, nullable=False),
    )
    for column in ("domain_ref", "problem_ref", "steps_ref"):
        op.add_column("plans", sa.Column(column, sa.String(64), nullable=True))
    op.add_column("replans", sa.Column("plans_ref", sa.String(64), nullable=True))
    op.add_column("trajectories", sa.Column("points_ref", sa.String(64), nullable=True))


def downgrade() -> None:
    op.drop_column("trajectories", "points_ref")
    op.drop_column("replans", "plans_ref")
    for column in ("domain_ref", "problem_ref", "steps_ref"):
        op.drop_column("plans", column)
    op.drop_table("blobs")
