"""Fixtures: an app on a fresh SQLite file (or PostgreSQL when SCREWSNAKE_TEST_POSTGRES is set)."""

from __future__ import annotations

import os
import uuid
from collections.abc import Iterator
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import create_engine, text

from app.main import create_app
from app.settings import Settings

POSTGRES = os.environ.get(
    "SCREWSNAKE_TEST_POSTGRES"
)  # e.g. postgresql://postgres@127.0.0.1:5432/postgres


def database_urls(tmp_path: Path) -> list[str]:
    return [f"sqlite:///{tmp_path / 'test.db'}"]


@pytest.fixture(params=["sqlite", "postgresql"])
def database_url(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[str]:
    """Every store test runs on SQLite, and on PostgreSQL when a server URL is given."""
    if request.param == "sqlite":
        yield f"sqlite:///{tmp_path / 'test.db'}"
        return
    if not POSTGRES:
        pytest.skip("set SCREWSNAKE_TEST_POSTGRES to a server URL to run on PostgreSQL")
    name = f"t_{uuid.uuid4().hex[:12]}"
    admin = create_engine(
        POSTGRES.replace("postgresql://", "postgresql+psycopg://", 1), isolation_level="AUTOCOMMIT"
    )
    with admin.connect() as conn:
        conn.execute(text(f"CREATE DATABASE {name}"))
    base = POSTGRES.rsplit("/", 1)[0]
    yield f"{base}/{name}"
    with admin.connect() as conn:
        conn.execute(text(f"DROP DATABASE IF EXISTS {name} WITH (FORCE)"))
    admin.dispose()


@pytest.fixture
def client(tmp_path: Path) -> Iterator[TestClient]:
    app = create_app(
        Settings(database_url=f"sqlite:///{tmp_path / 'api.db'}", max_running=4, warm_up=False)
    )
    with TestClient(app) as c:
        yield c
