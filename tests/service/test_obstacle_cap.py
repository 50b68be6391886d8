"""The obstacle cap is a setting (SCREWSNAKE_MAX_OBSTACLES, default 2000): walls of posts pass,
and beyond the cap the API answers 422 naming ``obstacles`` and the CLI names it too."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from fastapi.testclient import TestClient
from typer.testing import CliRunner

from app.cli import cli
from app.main import create_app
from app.missions.spec import MissionFileError, MissionSpec, parse_mission
from app.settings import Settings


def posts(n: int) -> list[dict[str, object]]:
    """``n`` hidden posts in rows along the north wall, clear of the start and the goal."""
    return [
        {"type": "circle", "x": -9.5 + 0.2 * (i % 95), "y": 9.5 - 0.2 * (i // 95), "radius": 0.05}
        for i in range(n)
    ]


def mission(n: int) -> dict[str, object]:
    return {"name": "cap", "goals": [{"x": -2, "y": -1}], "obstacles": posts(n)}


def test_a_wall_of_two_thousand_posts_validates_by_default() -> None:
    assert len(MissionSpec.model_validate(mission(2000)).obstacles) == 2000
    with pytest.raises(MissionFileError, match=r"obstacles: .*at most 2000 obstacles"):
        parse_mission(json.dumps(mission(2001)))


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
