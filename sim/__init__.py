"""Kinematic simulator of the four-unit screw-drive snake robot (docs/robot-model.md)."""
