"""The CLI's shared rich console and its error exit."""

from __future__ import annotations

import typer
from rich.console import Console

console = Console()


def fail(message: str) -> typer.Exit:
    """Print ``message`` as an error and return the exit to raise (code 2: bad input)."""
    console.print(f"[red]error:[/red] {message}")
    return typer.Exit(code=2)
