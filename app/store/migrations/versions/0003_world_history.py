"""A mission's world-model changes over model time, stored beside its trajectory (a blob), so
that a replay shows the world model as it was at each moment.

Revision ID: 0003
Revises: 0002
"""

import sqlalchemy as sa
from alembic import op

revision = "0003"
down_revision = "0002"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.add_column("trajectories", sa.Column("world_ref", sa.String(64), nullable=True))


def downgrade() -> None:
    op.drop_column("trajectories", "world_ref")
