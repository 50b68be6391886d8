"""Writing PDDL text (STRIPS + typing, and action costs where a domain has them) and portable names."""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field


def heading_name(degrees: float) -> str:
    """A portable object name for a heading: 0 -> h_0, -45 -> h_m45, 22.5 -> h_22p5."""
    value = round(float(degrees), 1)
    text = f"{abs(value):g}".replace(".", "p")
    return f"h_m{text}" if value < 0 else f"h_{text}"


def heading_degrees(name: str) -> float:
    body = name.removeprefix("h_")
    sign = -1.0 if body.startswith("m") else 1.0
    return sign * float(body.removeprefix("m").replace("p", "."))


def wrap_degrees(angle: float) -> float:
    """Into (-180, 180]."""
    a = math.fmod(angle + 180.0, 360.0)
    if a <= 0:
        a += 360.0
    return a - 180.0


@dataclass(frozen=True)
class Action:
    name: str
    parameters: Sequence[tuple[str, str]]  # (?var, type)
    precondition: Sequence[str]
    add: Sequence[str]
    delete: Sequence[str] = ()
    cost: str | None = None  # a numeric expression the action adds to (total-cost)

    def text(self, costs: bool = True) -> str:
        params = " ".join(f"{v} - {t}" for v, t in self.parameters)
        effects = [*self.add, *(f"(not {d})" for d in self.delete)]
        if costs and self.cost is not None:
            effects.append(f"(increase (total-cost) {self.cost})")
        return (
            f"  (:action {self.name}\n"
            f"    :parameters ({params})\n"
            f"    :precondition (and {' '.join(self.precondition)})\n"
            f"    :effect (and {' '.join(effects)}))"
        )


@dataclass(frozen=True)
class Domain:
    name: str
    types: Sequence[str]
    predicates: Sequence[str]
    actions: Sequence[Action]
    comment: str = ""
    constants: dict[str, Sequence[str]] = field(default_factory=dict)  # type -> names
    functions: Sequence[str] = ()  # static cost functions, e.g. "(move-cost ?a - lstate)"

    def text(self, costs: bool = True) -> str:
        """The domain's text; ``costs=False`` leaves the action costs out (plain STRIPS, for
        planners without ``:action-costs``, pyperplan among them)."""
        head = "".join(f"; {line}\n" for line in self.comment.splitlines())
        actions = "\n".join(a.text(costs) for a in self.actions)
        consts = " ".join(f"{' '.join(names)} - {t}" for t, names in self.constants.items())
        with_costs = costs and bool(self.functions)
        requirements = ":strips :typing :action-costs" if with_costs else ":strips :typing"
        functions = " ".join(["(total-cost) - number", *self.functions]) if with_costs else ""
        return (
            f"{head}(define (domain {self.name})\n"
            f"  (:requirements {requirements})\n"
            f"  (:types {' '.join(self.types)})\n"
            + (f"  (:constants {consts})\n" if consts else "")
            + f"  (:predicates {' '.join(self.predicates)})\n"
            + (f"  (:functions {functions})\n" if functions else "")
            + f"{actions})\n"
        )


@dataclass(frozen=True)
class Problem:
    name: str
    domain: str
    objects: Mapping[str, Sequence[str]]  # type -> names
    init: Iterable[str]
    goal: Sequence[str]
    comment: str = field(default="")
    costs: Iterable[str] = ()  # numeric facts of the cost functions, e.g. "(= (move-cost s1) 12)"

    def text(self, costs: bool = True) -> str:
        """The problem's text; with ``costs`` (and cost facts) its initial total cost, the cost
        facts and a metric minimising the total cost."""
        head = "".join(f"; {line}\n" for line in self.comment.splitlines())
        objects = "\n    ".join(
            f"{' '.join(names)} - {t}" for t, names in self.objects.items() if names
        )
        facts = list(self.costs) if costs else []
        init = "\n    ".join([*self.init, *(["(= (total-cost) 0)", *facts] if facts else [])])
        metric = "\n  (:metric minimize (total-cost))" if facts else ""
        return (
            f"{head}(define (problem {self.name})\n"
            f"  (:domain {self.domain})\n"
            f"  (:objects\n    {objects})\n"
            f"  (:init\n    {init})\n"
            f"  (:goal (and {' '.join(self.goal)})){metric})\n"
        )
