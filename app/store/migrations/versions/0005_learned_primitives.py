"""Lattice primitives the service learned for shapes the bundled library lacks: each entry as
in the library file, with its provenance (mission or job, seed, learner, rollouts) and the
library version it joined.

Revision ID: 0005
Revises: 0004
"""

import sqlalchemy as sa
from alembic import op

revision = "0005"
down_revision = "0004"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.create_table(
        "learned_primitives",
        sa.Column("id", sa.Integer, primary_key=True, autoincrement=True),
        sa.Column("shape", sa.String(64), nullable=False),
        sa.Column("primitive", sa.String(64), nullable=False),
        sa.Column("entry", sa.JSON, nullable=False),
        sa.Column("mission_id", sa.String(36), nullable=True),
        sa.Column("job_id", sa.String(36), nullable=True),
        sa.Column("seed", sa.Integer, nullable=False),
        sa.Column("learner", sa.String(40), nullable=False),
        sa.Column("rollouts", sa.Integer, nullable=False),
        sa.Column("library_version", sa.String(64), nullable=False),
        sa.Column("created_at", sa.DateTime(timezone=True), nullable=False),
        sa.UniqueConstraint("primitive", name="uq_learned_primitives_primitive"),
    )
    op.create_index("ix_learned_primitives_shape", "learned_primitives", ["shape"])


def downgrade() -> None:
    op.drop_index("ix_learned_primitives_shape", "learned_primitives")
    op.drop_table("learned_primitives")
