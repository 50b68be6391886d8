"""Library build time: serial, 1 and 2 local workers, and Ray when installed.

Target (bench/README.md): the paper primitives in <= 5 s on 2 cores; all of them, with the 132 lattice
primitives, in <= 30 s (the "all" suite is exactly what ``screwsnake library build`` bundles).
"""

from __future__ import annotations

import time

from primitives.build import build_library
from primitives.catalogue import default_specs, grid_specs, lattice_specs
from primitives.executors import Executor, LocalPoolExecutor, RayExecutor, SerialExecutor
from primitives.shapes import FIXED_SHAPES


def main() -> None:
    suites = {
        "paper (Fig. 6, 49)": default_specs(),
        "lattice (22 x 6 shapes, the gait's too, 132)": lattice_specs(),
        "all = bundled (paper + lattice, 181)": default_specs() + lattice_specs(),
        "grid (8 x 3 x 5 fixed shapes, 120)": grid_specs(FIXED_SHAPES),
    }
    executors: list[tuple[str, Executor]] = [
        ("serial", SerialExecutor()),
        ("local pool, 1 worker", LocalPoolExecutor(1)),
        ("local pool, 2 workers", LocalPoolExecutor(2)),
    ]
    try:
        import ray  # noqa: F401

        executors.append(("ray, local instance, 2 CPUs", RayExecutor(workers=2)))
    except ImportError:
        print("(ray not installed: pip install 'screwsnake[ray]' to include it)")
    for suite, specs in suites.items():
        reference = None
        for name, executor in executors:
            t0 = time.perf_counter()
            library = build_library(specs, executor=executor)
            wall = time.perf_counter() - t0
            same = (
                ""
                if reference is None
                else ("same" if library.to_json() == reference else "DIFFERENT")
            )
            reference = reference or library.to_json()
            worst = max(e.cost for e in library) * 100
            print(
                f"{suite:<38}{name:<30}{len(library):>5} primitives {wall:7.2f} s  worst {worst:.1f} cm  {same}"
            )


if __name__ == "__main__":
    main()
