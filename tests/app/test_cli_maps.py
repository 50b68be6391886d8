"""The command line on maps: ``screwsnake mission FILE --map office.yaml`` (the YAML's image
relative to the YAML) plans on a known map, ``--hidden-map`` senses it, and a bad map exits 2
naming the option and the parameter."""

from __future__ import annotations

import json
from pathlib import Path

from typer.testing import CliRunner

from app.cli import cli

MAPS = Path(__file__).parents[2] / "examples" / "maps"
MISSION = MAPS / "office-through-the-door.json"


def run(*args: str) -> tuple[int, str]:
    result = CliRunner().invoke(cli, ["mission", *args])
    return result.exit_code, result.output


def test_a_mission_on_a_known_map_from_its_yaml(tmp_path: Path) -> None:
    code, output = run(
        str(MISSION), "--map", str(MAPS / "office.yaml"), "--out", str(tmp_path / "m.png"), "--json"
    )
    assert code == 0, output
    summary = json.loads(output)
    assert summary["status"] == "succeeded" and summary["collisions"] == 0
    assert (tmp_path / "m.png").stat().st_size > 0


def test_a_hidden_map_must_be_binary_and_a_bad_map_names_the_parameter(tmp_path: Path) -> None:
    # the office has a band of unknown cells: hidden, it is no truth
    code, output = run(str(MISSION), "--hidden-map", str(MAPS / "office.yaml"))
    assert code == 2 and "maps.0.known" in output and "binary" in output
    bad = tmp_path / "bad.yaml"
    bad.write_text((MAPS / "office.yaml").read_text().replace("0.05", "0"))
    (tmp_path / "office.pgm").write_bytes((MAPS / "office.pgm").read_bytes())
    code, output = run(str(MISSION), "--map", str(bad))
    assert code == 2 and "--map" in output and "resolution" in output
    missing = tmp_path / "missing.yaml"
    missing.write_text("image: nowhere.pgm\nresolution: 0.05\n")
    code, output = run(str(MISSION), "--map", str(missing))
    assert code == 2 and "image" in output and "nowhere.pgm" in output
