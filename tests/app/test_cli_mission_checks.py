"""The CLI checks a mission as the API does: an unknown chain primitive is a clear error."""

from __future__ import annotations

import json
from pathlib import Path

from typer.testing import CliRunner

from app.cli import cli

runner = CliRunner()


def test_an_unknown_chain_primitive_is_named_not_a_crash(tmp_path: Path) -> None:
    mission = tmp_path / "chain.json"
    mission.write_text(json.dumps({"chain": [{"primitive": "P99", "until": {"duration": 5}}]}))
    result = runner.invoke(cli, ["mission", str(mission), "--out", str(tmp_path / "m.png")])
    assert result.exit_code != 0
    assert "chain.0: primitive 'P99' is not in the library" in result.output
    assert not isinstance(result.exception, KeyError)
