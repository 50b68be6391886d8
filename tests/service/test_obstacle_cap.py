"""The obstacle cap is a setting (SCREWSNAKE_MAX_OBSTACLES, default 10,000): walls of posts and
fields of thousands pass, and beyond the cap the API answers 422 naming ``obstacles`` and the
CLI names it too."""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import pytest
from fastapi.testclient import TestClient
from typer.testing import CliRunner

from app.cli import cli
from app.main import create_app
from app.missions.spec import MissionFileError, MissionSpec, parse_mission
from app.settings import Settings
from tests.service.test_api import wait_end


def posts(n: int) -> list[dict[str, object]]:
    """``n`` hidden posts in rows along the north wall, clear of the start and the goal."""
    return [
        {"type": "circle", "x": -9.5 + 0.2 * (i % 95), "y": 9.5 - 0.2 * (i // 95), "radius": 0.05}
        for i in range(n)
    ]


def mission(n: int) -> dict[str, object]:
    return {"name": "cap", "goals": [{"x": -2, "y": -1}], "obstacles": posts(n)}


def field_of_posts(n: int) -> dict[str, object]:
    """``n`` posts of 0.15 m on a 0.45 m grid over a 50 m arena, none within 1.5 m of the
    start (0, 0) or the goal (-2, -1)."""
    xs, ys = np.meshgrid(np.arange(-24.0, 24.0, 0.45), np.arange(-24.0, 24.0, 0.45))
    points = np.stack([xs.ravel(), ys.ravel()], axis=-1)
    clear = (np.hypot(*points.T) > 1.5) & (np.hypot(*(points - [-2, -1]).T) > 1.5)
    chosen = points[clear][:n]
    assert len(chosen) == n
    obstacles = [
        {"type": "circle", "x": round(float(x), 3), "y": round(float(y), 3), "radius": 0.075}
        for x, y in chosen
    ]
    bounds = {"xmin": -25, "xmax": 25, "ymin": -25, "ymax": 25}
    return {
        "name": "field",
        "goals": [{"x": -2, "y": -1}],
        "obstacles": obstacles,
        "bounds": bounds,
    }


def test_ten_thousand_posts_validate_by_default_and_quickly() -> None:
    started = time.perf_counter()
    assert len(MissionSpec.model_validate(field_of_posts(10_000)).obstacles) == 10_000
    assert time.perf_counter() - started < 5  # ~0.1 s: goals meet only the posts near them
    with pytest.raises(MissionFileError, match=r"obstacles: .*at most 10000 obstacles"):
        parse_mission(json.dumps(field_of_posts(10_001)))


def test_a_field_of_thousands_of_posts_is_accepted_and_run(client: TestClient) -> None:
    body = {**field_of_posts(3000), "time_limit": 120}
    created = client.post("/missions", json=body)
    assert created.status_code == 201, created.text
    end = wait_end(client, created.json()["id"], timeout=240)
    assert end["status"] == "succeeded", end["reason"]


def test_the_api_refuses_obstacles_beyond_the_setting_naming_the_field(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("SCREWSNAKE_MAX_OBSTACLES", "3")
    settings = Settings(database_url=f"sqlite:///{tmp_path / 'cap.db'}", warm_up=False)
    with TestClient(create_app(settings)) as c:
        r = c.post("/missions", json=mission(4))
        assert r.status_code == 422
        body = r.json()
        assert body["field"] == "obstacles"
        assert "at most 3 obstacles (SCREWSNAKE_MAX_OBSTACLES), got 4" in body["detail"]
        assert c.post("/missions", json=mission(3)).status_code == 201


def test_the_cli_applies_the_setting(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    file = tmp_path / "cap.json"
    file.write_text(json.dumps(mission(3)))
    monkeypatch.setenv("SCREWSNAKE_MAX_OBSTACLES", "2")
    result = CliRunner().invoke(cli, ["mission", str(file), "--out", str(tmp_path / "m.png")])
    assert result.exit_code != 0
    assert "obstacles: " in result.output and "at most 2 obstacles" in result.output


def test_a_bad_setting_stops_the_server_at_start(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("SCREWSNAKE_MAX_OBSTACLES", "0")
    with pytest.raises(ValueError, match="max_obstacles"):
        Settings.from_env()
