"""Request examples for the OpenAPI description, drawn from the example missions in examples/."""

from __future__ import annotations

import json
from functools import cache
from typing import Any

from app.paper_missions import examples_dir

# One of each kind: a single goal, hidden obstacles (reactive), a manual chain, a deformation,
# and the cluttered field the navigation domain is built for.
SHOWN = {
    "fig9a-single-goal": "One goal in an empty arena (the paper's Fig. 9a)",
    "fig9b-obstacles": "A hidden obstacle on the way, reactive domain (Fig. 9b)",
    "fig9b-chain": "A manual chain of library primitives, each for a duration (Fig. 9b)",
    "fig13b-deformation": "The body is deformed at a model time and replans (Fig. 13b)",
    "cluttered-field": "Known and hidden obstacles, navigation domain",
}


@cache
def mission_examples() -> dict[str, Any]:
    """``openapi_examples`` for ``POST /missions``: the example files that exist, by name."""
    out: dict[str, Any] = {}
    for name, summary in SHOWN.items():
        path = examples_dir() / f"{name}.json"
        if path.is_file():
            out[name] = {"summary": summary, "value": json.loads(path.read_text())}
    return out
