"""Generalisation to held-out goals: bilinear (paper) vs the blend generaliser, with refinement.

60 goals uniform in the 4 m x 4 m square around the start, per shape; the error is where the
generated parameters actually take the robot in one rollout.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

import numpy as np

from primitives.generalise import Generaliser
from primitives.interpolation import Interpolated, interpolate_in_shape
from primitives.library import load_bundled
from sim.rollout import rollout


def main() -> None:
    library = load_bundled()
    gen = Generaliser(library)
    goals = [(float(x), float(y)) for x, y in np.random.default_rng(2015).uniform(-2, 2, (60, 2))]
    methods: dict[str, Callable[[tuple[float, float], str], Interpolated]] = {
        "bilinear (paper eqs. 16-18)": lambda g, s: interpolate_in_shape(library, g, s),
        "blend (no rollouts)": gen.predict,
        "blend + Gauss-Newton": gen.refine,
        "blend + 5 PI² updates": lambda g, s: gen.refine(g, s, "pi2", budget=5),
    }
    print(f"{len(goals)} held-out goals in [-2, 2]^2; end-point error of one rollout")
    print(
        f"{'shape':<13}{'method':<30}{'median [cm]':>12}{'p90 [cm]':>10}{'max [cm]':>10}{'rollouts':>10}{'ms/goal':>9}"
    )
    for shape in ("straight", "zigzag", "arc", "semi-zigzag"):
        for name, method in methods.items():
            t0 = time.perf_counter()
            made = [method(g, shape) for g in goals]
            wall = (time.perf_counter() - t0) / len(goals) * 1e3
            errors = [100 * math.dist(rollout(ip.control()).end[0, :2], ip.goal) for ip in made]
            spent = np.median([float(ip.extra.get("rollouts", 0)) for ip in made])  # type: ignore[arg-type]
            print(
                f"{shape:<13}{name:<30}{np.median(errors):>12.2f}{np.percentile(errors, 90):>10.2f}"
                f"{max(errors):>10.2f}{spent:>10.0f}{wall:>9.2f}"
            )


if __name__ == "__main__":
    main()
