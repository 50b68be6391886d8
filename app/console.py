"""The CLI's shared rich console and its error exit."""

from __future__ import annotations

import json
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
