"""Engines for SQLite (a file, WAL, busy timeout) or PostgreSQL (by URL), migrated by Alembic."""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import orjson
from alembic import command
from alembic.config import Config
from sqlalchemy import Engine, create_engine, event
from sqlalchemy.engine import make_url
from sqlalchemy.exc import OperationalError

MIGRATIONS = Path(__file__).parent / "migrations"
_ORJSON = orjson.OPT_NON_STR_KEYS | orjson.OPT_SERIALIZE_NUMPY


def dumps(value: Any) -> str:
    """A JSON column's text, written by orjson. A mission of 10,000 obstacles is ~1 ms there and
    17 ms in the standard library's encoder, which is one C call holding the GIL throughout:
    the event loop's thread waited that long for a store write running in a worker thread.
    What orjson refuses (an object it does not know) is written by the standard library."""
    try:
        return orjson.dumps(value, option=_ORJSON).decode()
    except TypeError:
        return json.dumps(value)


def loads(text: str | bytes) -> Any:
    """A JSON column's value (orjson; text it refuses, e.g. ``NaN`` from an older row, by the
    standard library)."""
    try:
        return orjson.loads(text)
    except orjson.JSONDecodeError:
        return json.loads(text)


def make_engine(url: str) -> Engine:
    parsed = make_url(url)
    if parsed.get_backend_name() == "sqlite":
        if parsed.database and parsed.database != ":memory:":
            Path(parsed.database).parent.mkdir(parents=True, exist_ok=True)
        engine = create_engine(
            url,
            connect_args={"check_same_thread": False, "timeout": 30},
            json_serializer=dumps,
            json_deserializer=loads,
        )

        @event.listens_for(engine, "connect")
        def _pragmas(dbapi_connection: Any, _: Any) -> None:
            cur = dbapi_connection.cursor()
            cur.execute("PRAGMA journal_mode=WAL")
            cur.execute("PRAGMA synchronous=NORMAL")
            cur.execute("PRAGMA busy_timeout=30000")
            cur.execute("PRAGMA foreign_keys=ON")
            cur.close()

        return engine
    if parsed.get_backend_name() == "postgresql" and parsed.drivername == "postgresql":
        url = parsed.set(drivername="postgresql+psycopg").render_as_string(hide_password=False)
    return create_engine(url, pool_pre_ping=True, json_serializer=dumps, json_deserializer=loads)


def migrate(engine: Engine) -> None:
    """Bring the schema to the newest Alembic revision."""
    config = Config()
    config.set_main_option("script_location", str(MIGRATIONS))
    with engine.begin() as connection:
        config.attributes["connection"] = connection
        command.upgrade(config, "head")


class DatabaseLost(OperationalError):
    """The database file is not the one the server opened (deleted, or replaced by another):
    what is written now would be lost at the next start. A database failure (503)."""

    def __init__(self, detail: str) -> None:
        super().__init__(detail, None, FileNotFoundError(detail))
        self.reason = detail


@dataclass(frozen=True)
class DatabaseFile:
    """A SQLite database's file as the server opened it (device and inode). Deleted under the
    running server, SQLite goes on writing to the unlinked inode and every write seems to
    succeed; replaced, the server writes to the old file while the next start reads the new one.
    Either way nothing written from then on survives a restart."""

    path: Path
    device: int
    inode: int

    @classmethod
    def of(cls, engine: Engine) -> DatabaseFile | None:
        """The engine's database file (None: not a SQLite file, e.g. PostgreSQL or memory)."""
        url = engine.url
        if url.get_backend_name() != "sqlite" or url.database in (None, "", ":memory:"):
            return None
        path = Path(str(url.database)).resolve()
        st = os.stat(path)
        return cls(path, st.st_dev, st.st_ino)

    def problem(self) -> str | None:
        """Why the file is no longer the one opened (None while it is). Never names the path."""
        try:
            st = os.stat(self.path)
        except FileNotFoundError:
            return "the database file was deleted"
        except OSError as exc:
            return f"the database file cannot be looked at ({type(exc).__name__})"
        if (st.st_dev, st.st_ino) != (self.device, self.inode):
            return "the database file was replaced by another"
        return None

    def check(self) -> None:
        """Raise ``DatabaseLost`` when the file is no longer the one opened."""
        problem = self.problem()
        if problem is not None:
            raise DatabaseLost(problem)
