"""The parameter sets the paper publishes, with their goals (docs/robot-model.md, "How well it matches the paper")."""

from __future__ import annotations

from dataclasses import dataclass

from sim.controls import Control, FixedShape, PeriodicGait


@dataclass(frozen=True)
class PaperCase:
    """One published parameter set: screw speeds, a shape or phases, and the goal it aimed at."""

    name: str
    figure: str
    theta: tuple[float, float, float, float]
    goal: tuple[float, float]
    joints: tuple[float, float, float] | None = None
    phases: tuple[float, float, float] | None = None
    note: str = ""

    def control(self) -> Control:
        if self.phases is not None:
            return PeriodicGait.of(self.theta, self.phases)
        return FixedShape.of(self.theta, self.joints or (0.0, 0.0, 0.0))


PAPER_CASES: dict[str, PaperCase] = {
    c.name: c
    for c in (
        PaperCase("exp1", "Fig. 3a", (-0.35, 0.77, -0.30, 0.65), (-3, -3), (0, 0, 0)),
        PaperCase("exp2", "Fig. 3b", (0.16, 0.61, 0.14, 0.30), (2, -2), (0.5, -0.5, 0.5)),
        PaperCase(
            "exp3",
            "Fig. 4",
            (-0.39, -0.02, -0.32, -0.08),
            (-1, -3),
            (-0.05, 0.11, 0.02),
            note="not reproducible: nearly the inputs of Fig. 13 Set 1, whose goal is 5 m away",
        ),
        PaperCase("exp4", "Fig. 5", (-0.10, 0.53, -0.12, 0.50), (-2, -2), phases=(0.6, -0.5, -0.3)),
        PaperCase(
            "fig9-set1", "Fig. 9a", (-0.26, 0.42, -0.29, 0.34), (-3, -1), (0.05, 0.16, -0.02)
        ),
        PaperCase("fig13-set1", "Fig. 13a", (-0.38, -0.05, -0.42, 0.06), (-1, 2), (0, 0, 0)),
    )
}
