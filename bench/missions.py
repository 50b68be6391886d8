"""Model time / wall time per example mission, as fast as possible (DESIGN §8: >= 200x)."""

from __future__ import annotations

import time
from pathlib import Path

from app.executor.runner import MissionRunner
from app.missions.spec import load_mission
from primitives.library import load_bundled
from primitives.steering import Steering


def main() -> None:
    library = load_bundled()
    steering = Steering(library)
    print(
        f"{'mission':<28}{'status':<11}{'goals':>6}{'max err [cm]':>13}{'collisions':>11}{'replans':>8}"
        f"{'model [s]':>10}{'wall [s]':>9}{'ratio':>8}"
    )
    ratios = []
    for path in sorted(Path("examples").glob("*.json")):
        spec = load_mission(path)
        best = float("inf")
        for _ in range(3):  # best of three: the machine's noise is not the mission's cost
            t0 = time.perf_counter()
            result = MissionRunner(spec, library, steering).run()
            best = min(best, time.perf_counter() - t0)
        errors = [g.error for g in result.goals if g.error is not None]
        worst = max(errors) * 100 if errors else float("nan")
        ratio = result.model_time / best
        ratios.append(ratio)
        print(
            f"{spec.name:<28}{result.status:<11}{len(result.goals):>6}{worst:>13.1f}{result.collisions:>11}"
            f"{len(result.replans):>8}{result.model_time:>10.0f}{best:>9.2f}{ratio:>7.0f}x"
        )
    print(f"minimum ratio {min(ratios):.0f}x, median {sorted(ratios)[len(ratios) // 2]:.0f}x")


if __name__ == "__main__":
    main()
