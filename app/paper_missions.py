"""The paper's mission experiments as the paper describes them (Figs. 9b, 10, 11, 12, 13b):
each runs ``examples/paper/<name>.json`` and reads back what was executed, primitive by
primitive, from the mission result (the same log ``screwsnake mission`` and the API show).

Where a chain's goals G1..G3 are, the library predicts: each step starts at the heading the
primitives were learned from and moves by its primitive's recorded end (an interpolation by
the same bilinear blend of its sources' ends, eqs. 16-18).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from app.executor.context import MissionResult
from app.executor.runner import MissionRunner
from app.missions.spec import MissionSpec, load_mission
from primitives.library import Library
from primitives.paper_moves import interpolated

Row = tuple[str, str, str]  # what, the paper, ours


def examples_dir() -> Path:
    """Where the example missions live: the checkout's examples/ folder."""
    here = Path(str(resources.files("app"))).parent / "examples"
    return here if here.is_dir() else Path("examples")


def paper_spec(name: str) -> MissionSpec:
    """The mission file of a paper experiment (examples/paper/)."""
    return load_mission(examples_dir() / "paper" / f"{name}.json")


@dataclass(frozen=True)
class PaperRun:
    """A paper mission run: its spec, the runner (for its world model) and the result."""

    spec: MissionSpec
    runner: MissionRunner
    result: MissionResult

    def behaviours(self) -> list[dict[str, Any]]:
        """What moved the robot, in order: executed entries that ran primitives (turns in
        place between chain steps and holds left out), each with its labels as a set."""
        return [
            {**e, "sources": frozenset(e["labels"])}
            for e in self.result.executed
            if e["labels"] and not str(e["action"]).startswith("turn to")
        ]

    def chain(self) -> list[str]:
        """The behaviours as the paper writes a chain: P1s, P4z, P8s+P1s+P2s, ..."""
        return ["+".join(sorted(e["labels"])) for e in self.behaviours()]

    def step_ends(self) -> list[tuple[float, float]]:
        """Where each chain step's primitive run ended (chains only)."""
        ends = []
        for i in range(len(self.spec.chain)):
            tag = f"(chain step {i})"
            runs = [
                e
                for e in self.result.executed
                if str(e["action"]).endswith(tag) and not str(e["action"]).startswith("turn")
            ]
            if runs and runs[-1]["end"] is not None:
                ends.append((float(runs[-1]["end"][0]), float(runs[-1]["end"][1])))
        return ends


def run_paper(name: str, library: Library) -> PaperRun:
    """Run a paper experiment's mission to its end."""
    spec = paper_spec(name)
    runner = MissionRunner(spec, library)
    return PaperRun(spec, runner, runner.run())


def chain_targets(spec: MissionSpec, library: Library) -> list[tuple[float, float]]:
    """Where the library says each chain step ends, from the start (headings reset to the
    start's before every step, as the chain's ``heading`` asks)."""
    x, y = spec.start.x, spec.start.y
    out = []
    for step in spec.chain:
        psi = math.radians(step.heading) if step.heading is not None else spec.start.psi
        if step.primitive is not None:
            end = np.asarray(library.get(step.primitive).end, dtype=float)
        else:
            assert step.interpolate is not None
            entries = [library.get(n) for n in step.interpolate.from_]
            move = interpolated(entries, step.interpolate.goal)
            end = move.velocity * max(float(e.rollout.duration) for e in entries)
        c, s = math.cos(psi), math.sin(psi)
        x, y = x + c * end[0] - s * end[1], y + s * end[0] + c * end[1]
        out.append((round(x, 4), round(y, 4)))
    return out


def chain_rows(run: PaperRun) -> list[Row]:
    """The executed behaviours, one row each, for the CLI table."""
    rows = []
    for e in run.behaviours():
        what = f"{e['from']:g}-{e['to']:g} s {e['action']}"
        towards = "" if e.get("towards_deg") is None else f" towards {e['towards_deg']:g} deg"
        rows.append((what, "", f"{e['method']}: {'+'.join(e['labels'])}{towards}"))
    return rows


def outcome_rows(run: PaperRun, paper: str) -> list[Row]:
    r = run.result
    errors = ", ".join(f"{g.error * 100:.1f}" for g in r.goals if g.error is not None)
    return [
        ("outcome", paper, f"{r.status}: {r.reason}"),
        ("goal errors", "about 25 cm on the real robot", f"{errors or '-'} cm"),
        ("collisions / replans", "-", f"{r.collisions} / {len(r.replans)}"),
    ]
