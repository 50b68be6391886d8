"""Kinematic simulator of the four-unit screw-drive snake robot (kinematics.md)."""
