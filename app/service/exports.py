"""What a mission exports, made off the event loop: its plan versions' PDDL problems, rendered
from their stored sources, whole or as an answer (size-capped, gzip-compressed when asked).

These run in the service's process pool (``app.service.validation``): a plan version's problem
can be tens of megabytes of text, seconds of pure Python to write, and the worker that planned
it stored only what regenerates it (``app.executor.plan_versions``).
"""

from __future__ import annotations

import gzip
from collections.abc import Sequence
from dataclasses import dataclass

from app.executor.plan_versions import render

GZIP_LEVEL = 6  # gzip's default: PDDL problems shrink ~15-fold


@dataclass(frozen=True)
class Answer:
    """A problem's bytes as sent (gzip-compressed when ``gzipped``) and its text's size."""

    data: bytes
    size: int
    gzipped: bool


@dataclass(frozen=True)
class TooLarge:
    """The text is larger than the answer may be."""

    size: int


Stored = str | bytes  # a problem's text as stored (older rows), or its source


def problem_text(stored: Stored) -> str:
    """A plan version's problem text: rendered from its source, or as stored."""
    return render(stored) if isinstance(stored, bytes) else stored


def answer(stored: Stored, limit: int, gzipped: bool) -> Answer | TooLarge:
    """A plan version's problem as an answer of at most ``limit`` bytes of text."""
    raw = problem_text(stored).encode("utf-8")
    if len(raw) > limit:
        return TooLarge(len(raw))
    data = gzip.compress(raw, GZIP_LEVEL, mtime=0) if gzipped else raw
    return Answer(data, len(raw), gzipped)


def inline_texts(stored: Sequence[Stored], budget: int) -> list[tuple[str | None, int | None]]:
    """The problems of a mission's versions, oldest first, with their sizes, while they fit
    in ``budget`` bytes of text in all: the first that does not has its size only, and none
    after it is rendered (no text, no size): a request renders at most ``budget`` bytes and
    one problem more."""
    out: list[tuple[str | None, int | None]] = []
    for item in stored:
        if budget < 0:
            out.append((None, None))
            continue
        text = problem_text(item)
        size = len(text.encode("utf-8"))
        if size > budget:
            out.append((None, size))
            budget = -1
            continue
        budget -= size
        out.append((text, size))
    return out
