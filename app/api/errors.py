"""Errors as application/problem+json (RFC 9457), with the offending field named."""

from __future__ import annotations

import logging
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from starlette.exceptions import HTTPException as StarletteHTTPException

PROBLEM = "application/problem+json"
log = logging.getLogger("screwsnake.api")


def problem(status: int, title: str, detail: str = "", **extra: Any) -> JSONResponse:
    body = {"type": "about:blank", "title": title, "status": status, "detail": detail, **extra}
    return JSONResponse(body, status_code=status, media_type=PROBLEM)


def field_of(loc: tuple[Any, ...] | list[Any]) -> str:
    """``("body", "goals", 0, "x")`` -> ``goals.0.x``; union-member names are left out."""
    parts = [str(p) for p in loc if p not in ("body", "query", "path", "header")]
    parts = [p for p in parts if not p.endswith("Spec") and p not in ("function-after[_one()]",)]
    return ".".join(parts) or "body"


def install(app: FastAPI) -> None:
    @app.exception_handler(RequestValidationError)
    async def _invalid(_: Request, exc: RequestValidationError) -> JSONResponse:
        errors = []
        for e in exc.errors():
            field = field_of(e.get("loc", ()))
            msg = str(e.get("msg", "invalid"))
            if field in ("body", "") and msg.startswith("Value error, ") and ":" in msg:
                field = msg.removeprefix("Value error, ").split(":", 1)[
                    0
                ]  # model-level checks name it
            errors.append({"field": field, "message": msg, "type": e.get("type", "")})
        first = errors[0] if errors else {"field": "body", "message": "invalid"}
        return problem(
            422,
            "Invalid request",
            f"{first['field']}: {first['message']}",
            field=first["field"],
            errors=errors,
        )

    @app.exception_handler(StarletteHTTPException)
    async def _http(_: Request, exc: StarletteHTTPException) -> JSONResponse:
        response = problem(
            exc.status_code,
            str(exc.detail) if exc.status_code < 500 else "Server error",
            str(exc.detail),
        )
        for key, value in (exc.headers or {}).items():
            response.headers[key] = value
        return response

    @app.exception_handler(Exception)
    async def _crash(_: Request, exc: Exception) -> JSONResponse:
        log.exception("unhandled error")
        return problem(500, "Server error", type(exc).__name__)


PROBLEM_SCHEMA: dict[str, Any] = {
    "title": "Problem",
    "type": "object",
    "properties": {
        "type": {"type": "string"},
        "title": {"type": "string"},
        "status": {"type": "integer"},
        "detail": {"type": "string"},
        "field": {"type": "string"},
        "errors": {"type": "array", "items": {"type": "object"}},
    },
    "required": ["type", "title", "status"],
}
ERROR_CODES = {
    "401": "API key missing or wrong",
    "404": "Not found",
    "409": "Conflict",
    "422": "Invalid request",
}


def document(app: FastAPI) -> None:
    """Say in the OpenAPI schema what errors really look like: problem+json, 401/404/409/422."""
    from fastapi.openapi.utils import get_openapi

    def openapi() -> dict[str, Any]:
        if app.openapi_schema:
            return app.openapi_schema
        schema = get_openapi(
            title=app.title, version=app.version, summary=app.summary, routes=app.routes
        )
        schema.setdefault("components", {}).setdefault("schemas", {})["Problem"] = PROBLEM_SCHEMA
        ref = {"$ref": "#/components/schemas/Problem"}
        for path, item in schema.get("paths", {}).items():
            for method, op in item.items():
                responses = op.setdefault("responses", {})
                codes = ["422"]
                if "{" in path or path in ("/plan",):
                    codes.append("404")
                if method in ("post", "put", "delete"):
                    codes += ["401", "409"]
                for code in codes:
                    responses[code] = {
                        "description": ERROR_CODES[code],
                        "content": {PROBLEM: {"schema": ref}},
                    }
                if path == "/readyz":
                    responses["503"] = {
                        "description": "Not ready",
                        "content": {"application/json": {"schema": {"type": "object"}}},
                    }
        app.openapi_schema = schema
        return schema

    app.openapi = openapi  # type: ignore[method-assign]
