"""`screwsnake simulate` prints the end pose and writes a trajectory plot."""

from pathlib import Path

from typer.testing import CliRunner

from app.cli import cli

runner = CliRunner()


def test_simulate_a_paper_case_writes_a_png(tmp_path: Path) -> None:
    out = tmp_path / "exp4.png"
    result = runner.invoke(cli, ["simulate", "--case", "exp4", "--out", str(out)])
    assert result.exit_code == 0, result.output
    assert "-2.045" in result.output and "distance 0.068 m" in result.output
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_simulate_explicit_parameters(tmp_path: Path) -> None:
    out = tmp_path / "fwd.png"
    args = [
        "simulate",
        "--theta",
        "-1",
        "1",
        "-1",
        "1",
        "--joints",
        "0",
        "0",
        "0",
        "--out",
        str(out),
    ]
    result = runner.invoke(cli, args)
    assert result.exit_code == 0, result.output
    assert "-7.500" in result.output and out.exists()


def test_simulate_rejects_bad_input_with_a_clear_message(tmp_path: Path) -> None:
    result = runner.invoke(
        cli, ["simulate", "--theta", "0", "0", "0", "nan", "--out", str(tmp_path / "x.png")]
    )
    assert result.exit_code == 2 and "theta" in result.output
    result = runner.invoke(cli, ["simulate", "--case", "nope"])
    assert result.exit_code == 2 and "unknown" in result.output
