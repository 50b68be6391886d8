"""The primitive library the service runs on."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, Path, Query

from app.api.deps import Svc
from app.api.errors import ApiError, responses
from app.api.schemas import PrimitiveList, PrimitiveSummary
from primitives.shapes import SHAPES, is_shape

router = APIRouter(tags=["primitives"])


@router.get("/primitives", response_model=PrimitiveList, responses=responses(422))
def list_primitives(
    svc: Svc,
    shape: Annotated[
        str | None,
        Query(
            max_length=40,
            description=(
                f"only this body shape: one of {', '.join(SHAPES)}, or a learned shape's name "
                "(body-p090-m030-p060: its joints in hundredths of a radian)"
            ),
        ),
    ] = None,
) -> PrimitiveList:
    """The library's primitives (paper and lattice; the bundled file's and those learned
    since), optionally of one shape."""
    if shape is not None and not is_shape(shape):
        # the same answer as a mission naming an unknown shape
        raise ApiError(422, f"shape: unknown {shape!r}; known: {', '.join(SHAPES)}", "shape")
    items = [
        PrimitiveSummary(
            id=e.id,
            label=e.label,
            shape=e.shape,
            space=e.space,
            family=e.family,
            duration=e.rollout.duration,
            goal=list(e.goal),
            direction=round(e.direction, 3),
            cost=e.cost,
        )
        for e in svc.library
        if shape is None or e.shape == shape
    ]
    return PrimitiveList(library=svc.library_version, count=len(items), items=items)


@router.get("/primitives/{name}", responses=responses(404))
def get_primitive(
    name: Annotated[str, Path(description="a primitive's id or paper label (P1s)")], svc: Svc
) -> dict[str, Any]:
    """One library entry in the library file's format, plus its travel ``direction`` (rad)."""
    if name not in svc.library:
        raise ApiError(404, f"primitive {name!r} not found")
    entry = svc.library.get(name)
    data: dict[str, Any] = entry.model_dump(mode="json")
    return data | {"direction": entry.direction}
