"""The symbolic layer: PDDL domains and problems from the library, planning and replanning."""
