"""A manual chain's steps: a primitive (or an interpolated one) until a condition."""

from __future__ import annotations

from typing import Annotated

from pydantic import ConfigDict, Field, model_validator
from pydantic import Strict as StrictNumber

from app.missions.parts import Coord, Strict


class Reach(Strict):
    """A chain step ends when the tracked point is this close to a point."""

    x: Coord
    """x, metres"""
    y: Coord
    """y, metres"""
    tolerance: Annotated[float, StrictNumber(), Field(allow_inf_nan=False, gt=0, le=5.0)] = 0.1
    """metres"""


class Until(Strict):
    """When a chain step ends: a point reached, a duration, or a sensor threshold."""

    reach: Reach | None = None
    """end when this point is reached"""
    duration: Annotated[float, StrictNumber(), Field(allow_inf_nan=False, gt=0, le=1e5)] | None = (
        None
    )
    """end after this long, model seconds"""
    sensor: str | None = None
    """end on this sensor's reading ("ir", "ring0", ...) crossing below or above"""
    below: Annotated[float, StrictNumber(), Field(allow_inf_nan=False)] | None = None
    """the sensor threshold, metres: end when the reading falls below it"""
    above: Annotated[float, StrictNumber(), Field(allow_inf_nan=False)] | None = None
    """the sensor threshold, metres: end when the reading rises above it"""
    timeout: Annotated[float, StrictNumber(), Field(allow_inf_nan=False, gt=0, le=1e5)] | None = (
        None
    )
    """give up (the mission fails) after this long, model seconds"""

    @model_validator(mode="after")
    def _one(self) -> Until:
        kinds = [self.reach is not None, self.duration is not None, self.sensor is not None]
        if sum(kinds) != 1:
            raise ValueError("give exactly one of reach, duration or sensor")
        if self.sensor is not None and (self.below is None) == (self.above is None):
            raise ValueError("a sensor condition needs exactly one of below or above")
        return self


class InterpolateSpec(Strict):
    """A primitive interpolated from three library primitives (the paper's eqs. 16-18)."""

    from_: Annotated[list[str], Field(alias="from", min_length=3, max_length=3)]
    """three library primitive ids or labels"""
    goal: tuple[Coord, Coord]
    """the displacement to reach (start frame), metres"""
    model_config = ConfigDict(
        extra="forbid", frozen=True, populate_by_name=True, use_attribute_docstrings=True
    )


class ChainStep(Strict):
    """One step of a manual chain: a primitive (or an interpolated one) until a condition."""

    primitive: str | None = None
    """a library primitive's id or label (e.g. P4s)"""
    interpolate: InterpolateSpec | None = None
    """or a primitive interpolated from three"""
    until: Until
    """when the step ends"""
    heading: Annotated[
        float | None,
        StrictNumber(),
        Field(
            allow_inf_nan=False,
            ge=-360,
            le=360,
            description=(
                "turn in place to this world heading (degrees) before the step, with the step "
                "shape's library turns: a primitive then moves as it was learned from the start pose"
            ),
        ),
    ] = None

    @model_validator(mode="after")
    def _one(self) -> ChainStep:
        if (self.primitive is None) == (self.interpolate is None):
            raise ValueError("give exactly one of primitive or interpolate")
        return self
