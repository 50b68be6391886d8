"""The primitive library the service runs on."""

from __future__ import annotations

from typing import Annotated, Any

from fastapi import APIRouter, HTTPException, Query

from app.api.deps import Svc

router = APIRouter(tags=["primitives"])


@router.get("/primitives")
def list_primitives(
    svc: Svc, shape: Annotated[str | None, Query(max_length=40)] = None
) -> dict[str, Any]:
    entries = [e for e in svc.library if shape is None or e.shape == shape]
    items = [
        {
            "id": e.id,
            "label": e.label,
            "shape": e.shape,
            "space": e.space,
            "family": e.family,
            "duration": e.rollout.duration,
            "goal": list(e.goal),
            "direction": round(e.direction, 3),
            "cost": e.cost,
        }
        for e in entries
    ]
    return {"library": svc.library_version, "count": len(items), "items": items}


@router.get("/primitives/{name}")
def get_primitive(name: str, svc: Svc) -> dict[str, Any]:
    if name not in svc.library:
        raise HTTPException(404, f"primitive {name!r} not found")
    entry = svc.library.get(name)
    data: dict[str, Any] = entry.model_dump(mode="json")
    return data | {"direction": entry.direction}
