"""Occupancy-grid maps (ROS map_server format), stored once by content hash: their parameters
and their image as posted, which missions name by id.

Revision ID: 0004
Revises: 0003
"""

import sqlalchemy as sa
from alembic import op

revision = "0004"
down_revision = "0003"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "maps",
        sa.Column("id", sa.String(32), primary_key=True),
        sa.Column("name", sa.String(120), nullable=False),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
        sa.Column("meta", sa.JSON, nullable=False),
        sa.Column("image", sa.LargeBinary, nullable=False),
    )
    op.create_index("ix_maps_created_at", "maps", ["created_at"])


def downgrade() -> None:
    op.drop_index("ix_maps_created_at", "maps")
    op.drop_table("maps")
