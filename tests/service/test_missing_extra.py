"""An executor whose package is not installed: one line saying what to install, a non-zero exit."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from app.cli import cli
from app.main import MissingExtra, create_app
from app.settings import Settings

ROOT = Path(__file__).parents[2]
WITHOUT_RAY = "import sys; sys.modules['ray'] = None; "  # import ray now fails, as if absent


def test_the_server_says_what_to_install_and_exits(tmp_path: Path) -> None:
    env = {
        **os.environ,
        "SCREWSNAKE_EXECUTOR": "ray",
        "SCREWSNAKE_DATABASE_URL": f"sqlite:///{tmp_path / 'x.db'}",
    }
    done = subprocess.run(
        [sys.executable, "-c", WITHOUT_RAY + "import app.main"],
        env=env,
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 1
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in done.stderr, done.stderr
    assert "pip install 'screwsnake[ray]'" in lines[0] and "SCREWSNAKE_EXECUTOR=ray" in lines[0]


def test_serve_and_create_app_refuse_too(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "ray", None)
    with pytest.raises(MissingExtra, match=r"screwsnake\[ray\]"):
        create_app(Settings(executor="ray"))
    monkeypatch.setenv("SCREWSNAKE_EXECUTOR", "ray")
    result = CliRunner().invoke(cli, ["serve"])
    assert result.exit_code == 2 and "pip install 'screwsnake[ray]'" in result.output
