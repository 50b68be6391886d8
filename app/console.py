"""The CLI's shared rich console and its error exit."""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Annotated, Any

import typer
from pydantic import ValidationError
from rich.console import Console
from rich.markup import escape

console = Console()
# The --json option every command takes: one JSON document on stdout, for scripts.
AsJson = Annotated[bool, typer.Option("--json", help="print the result as JSON (for scripts)")]


def emit(data: Any) -> None:
    """Print ``data`` as one JSON document (plain stdout: no colour, no wrapping)."""
    typer.echo(json.dumps(data, indent=2, default=str))


def numbers(metavar: str) -> Callable[[str], float]:
    """A parser for each number of a multi-number option (``--goal X Y``): an option where a
    number should be (``--goal -3 --shape straight``) says how many the option takes."""
    count = len(metavar.split())

    def parse(value: str | float) -> float:
        if isinstance(value, int | float):  # a default
            return float(value)
        if value.startswith("--"):
            raise typer.BadParameter(
                f"takes {count} numbers, {metavar}; got the option {value} where a number goes"
            )
        try:
            return float(value)
        except ValueError:
            raise typer.BadParameter(f"{value!r} is not a number ({metavar})") from None

    return parse


def fail(message: str) -> typer.Exit:
    """Print ``message`` as an error and return the exit to raise (code 2: bad input)."""
    # the message is text (it may hold brackets, e.g. "screwsnake[ray]"), one line however wide
    console.print(f"[red]error:[/red] {escape(message)}", soft_wrap=True)
    return typer.Exit(code=2)


def invalid(exc: ValidationError, names: dict[str, str] | None = None) -> typer.Exit:
    """A pydantic error (the API's own request model) as a CLI error naming the option.

    ``names`` maps model fields to option names (``max_updates`` -> ``max-updates``).
    """
    first = exc.errors()[0]
    loc = [str(p) for p in first.get("loc", ())]
    msg = str(first.get("msg", "invalid")).removeprefix("Value error, ")
    if loc:
        loc[0] = (names or {}).get(loc[0], loc[0].replace("_", "-"))
        return fail(f"{'.'.join(loc)}: {msg}")
    return fail(msg)  # a model-level check names its field itself
