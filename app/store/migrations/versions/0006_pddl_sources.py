"""Plan versions keep what regenerates their PDDL problem (a worker's compact source, rendered
when someone asks) instead of its text.

Revision ID: 0006
Revises: 0005
"""

import sqlalchemy as sa
from alembic import op

revision = "0006"
down_revision = "0005"
branch_labels = None
depends_on = None


def upgrade() -> None:
    op.add_column("plans", sa.Column("source_ref", sa.String(64), nullable=True))


def downgrade() -> None:
    op.drop_column("plans", "source_ref")
