"""The navigation domain's PDDL: move(from, to, heading, shape) and goal visits."""

from __future__ import annotations

from domain.pddl import Action, Domain


def navigation_domain() -> Domain:
    return Domain(
        "screwsnake-navigation",
        ["waypoint", "heading", "shape", "stage"],
        [
            "(at ?w - waypoint)",
            "(edge ?a - waypoint ?b - waypoint ?h - heading)",
            "(groundable ?h - heading ?s - shape)",
            "(body ?s - shape)",
            "(goal-point ?w - waypoint)",
            "(visited ?w - waypoint)",
            "(stage ?k - stage)",
            "(goal-at ?k - stage ?w - waypoint)",
            "(next ?k - stage ?k2 - stage)",
        ],
        [
            Action(
                "move",
                [("?a", "waypoint"), ("?b", "waypoint"), ("?h", "heading"), ("?s", "shape")],
                ["(at ?a)", "(edge ?a ?b ?h)", "(groundable ?h ?s)", "(body ?s)"],
                ["(at ?b)"],
                ["(at ?a)"],
            ),
            Action("visit", [("?w", "waypoint")], ["(at ?w)", "(goal-point ?w)"], ["(visited ?w)"]),
            Action(
                "visit-next",
                [("?w", "waypoint"), ("?k", "stage"), ("?k2", "stage")],
                ["(at ?w)", "(stage ?k)", "(goal-at ?k ?w)", "(next ?k ?k2)"],
                ["(stage ?k2)"],
                ["(stage ?k)"],
            ),
        ],
        comment=(
            "screwsnake navigation: move along roadmap edges with headings the primitive library\n"
            "can ground in the current body shape; goals are visited in any order (visit) or in\n"
            "the given order (visit-next over stages). Blocked edges are absent from (edge ...)."
        ),
    )
