"""The sensed layer: log-odds occupancy from the head's range readings (``layer``), with the
beams' geometry (``beams``) and its compiled halves (``clearing``, ``marking``)."""

from domain.world.sensed.layer import SensedLayer

__all__ = ["SensedLayer"]
