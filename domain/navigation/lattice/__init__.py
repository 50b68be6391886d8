"""The state lattice: states, the library's primitives as motions, their costs, the pyperplan
task of a leg and its PDDL export."""
