"""Store size per mission: what each example mission leaves in the database, as the first
layout stored it (every text and JSON inline) and as stored now (PDDL, actions and the
trajectory in compressed, content-addressed blobs; the domain text once). Target: <= 50 kB for
examples/cluttered-field.json. Prints figures, never asserts.
"""

from __future__ import annotations

import json
import sys
import tempfile
import time
from datetime import datetime
from pathlib import Path
from typing import Any

from fastapi.testclient import TestClient
from sqlalchemy import Engine, create_engine, select

from app.main import create_app
from app.settings import Settings
from app.store.models import (
    BlobRow,
    MissionRow,
    PlanRow,
    ReplanRow,
    TrajectoryRow,
    TransitionRow,
)

EXAMPLES = Path(__file__).parents[1] / "examples"
MISSIONS = ("cluttered-field", "fig13b-deformation", "fig9b-obstacles", "fig9a-single-goal")


def size(value: Any) -> int:
    """Bytes a column value takes as stored (JSON as its text)."""
    if value is None:
        return 0
    if isinstance(value, bytes):
        return len(value)
    if isinstance(value, str):
        return len(value.encode())
    if isinstance(value, int | float | datetime):
        return 8
    return len(json.dumps(value, separators=(",", ":")).encode())


def mission_bytes(engine: Engine, mission_id: str) -> tuple[int, int]:
    """(bytes stored now, bytes the inline layout would hold) for one mission's rows."""
    stored = inline = 0
    with engine.connect() as conn:
        refs: set[str] = set()
        for table in (MissionRow, TransitionRow, PlanRow, ReplanRow, TrajectoryRow):
            key = table.id if table is MissionRow else table.mission_id  # type: ignore[attr-defined]
            for row in conn.execute(select(table).where(key == mission_id)).mappings():
                for column, value in row.items():
                    stored += size(value)
                    if column.endswith("_ref"):
                        refs |= {value} if value else set()
                    else:
                        inline += size(value)
        for blob in conn.execute(select(BlobRow).where(BlobRow.sha256.in_(refs))).mappings():
            stored += len(blob["data"])
            inline += blob["size"]
    return stored, inline


def main() -> None:
    names = sys.argv[1:] or list(MISSIONS)
    with tempfile.TemporaryDirectory() as tmp:
        url = f"sqlite:///{Path(tmp) / 'bench.db'}"
        app = create_app(Settings(database_url=url, max_running=1))
        engine = create_engine(url)
        print(f"{'mission':<22}{'status':<11}{'plans':>6}{'inline [kB]':>13}{'stored [kB]':>13}")
        with TestClient(app) as client:
            for name in names:
                body = json.loads((EXAMPLES / f"{name}.json").read_text())
                mission = client.post("/missions", json=body).json()
                deadline = time.monotonic() + 600
                while time.monotonic() < deadline:
                    got = client.get(f"/missions/{mission['id']}").json()
                    if got["status"] in ("succeeded", "failed", "cancelled"):
                        break
                    time.sleep(0.2)
                plans = len(client.get(f"/missions/{mission['id']}/pddl").json())
                stored, inline = mission_bytes(engine, mission["id"])
                print(
                    f"{name:<22}{got['status']:<11}{plans:>6}"
                    f"{inline / 1000:>13.1f}{stored / 1000:>13.1f}"
                )
        engine.dispose()


if __name__ == "__main__":
    main()
