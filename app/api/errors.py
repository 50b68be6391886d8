"""Errors as application/problem+json (RFC 9457): one shape for every error of every route.

``type`` is ``about:blank``, so ``title`` is the generic HTTP phrase ("Not Found"); ``detail``
says what went wrong for this request; ``field`` and ``errors`` name what is at fault when a
request field is. Routes declare the codes they can return with ``responses(...)``.
"""

from __future__ import annotations

import logging
from http import HTTPStatus
from typing import Any

from fastapi import FastAPI, Request
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse
from pydantic import BaseModel, Field
from starlette.exceptions import HTTPException as StarletteHTTPException

PROBLEM = "application/problem+json"
log = logging.getLogger("screwsnake.api")
BODY_PARSE_ERROR = "There was an error parsing the body"  # FastAPI's 400 for an unreadable body
SEND_JSON = "send JSON (application/json)"
# pydantic's error types when the body as a whole is no JSON object (a form, plain text, empty)
NOT_AN_OBJECT = {"model_attributes_type", "dict_type", "model_type", "missing"}


class FieldError(BaseModel):
    """One thing wrong with the request."""

    field: str = Field(description="dotted path of the field at fault, e.g. `goals.0.x`; `body`")
    message: str = Field(description="what is wrong with it")
    type: str = Field(default="", description="machine-readable kind (pydantic's error type)")


class Problem(BaseModel):
    """An error (RFC 9457 problem details). Every error answer of this API has this shape."""

    type: str = Field(default="about:blank", description="always `about:blank`: see `status`")
    title: str = Field(description="the generic HTTP status phrase, e.g. `Not Found`")
    status: int = Field(description="the HTTP status code, repeated")
    detail: str = Field(description="what went wrong with this request, specifically")
    field: str | None = Field(
        default=None, description="the request field at fault, when one is (dotted path)"
    )
    errors: list[FieldError] | None = Field(
        default=None, description="every field at fault, when one is (the first is `field`)"
    )


class ApiError(StarletteHTTPException):
    """An HTTP error with an optional offending field (``field`` and ``errors`` in the body)."""

    def __init__(
        self,
        status: int,
        detail: str,
        field: str | None = None,
        headers: dict[str, str] | None = None,
    ) -> None:
        super().__init__(status, detail, headers)
        self.field = field


def title_of(status: int) -> str:
    try:
        return HTTPStatus(status).phrase
    except ValueError:
        return "Error"


def problem(status: int, detail: str, field: str | None = None, **extra: Any) -> JSONResponse:
    """The one error body: generic title, specific detail, the field when one is at fault."""
    body: dict[str, Any] = {
        "type": "about:blank",
        "title": title_of(status),
        "status": status,
        "detail": detail,
    }
    if field is not None:
        body["field"] = field
        body["errors"] = extra.pop("errors", None) or [
            {"field": field, "message": detail.removeprefix(f"{field}: "), "type": "value_error"}
        ]
    body.update(extra)
    return JSONResponse(body, status_code=status, media_type=PROBLEM)


def field_of(loc: tuple[Any, ...] | list[Any], kind: str = "") -> str:
    """``("body", "goals", 0, "x")`` -> ``goals.0.x``; union-member names are left out; a JSON
    syntax error's location is a character offset, not a field: ``body``."""
    if kind == "json_invalid":
        return "body"
    parts = [str(p) for p in loc if p not in ("body", "query", "path", "header")]
    parts = [p for p in parts if not p.endswith("Spec") and p not in ("function-after[_one()]",)]
    return ".".join(parts) or "body"


def body_problem(request: Request, kind: str) -> str:
    """Why a body is not the JSON object a route takes: empty, sent as another media type, or
    JSON of another kind (a list, a number)."""
    if kind == "missing":
        return "the body is empty"
    media = request.headers.get("content-type", "").split(";")[0].strip().lower()
    if media and media != "application/json" and not media.endswith("+json"):
        return f"the body came as {media}"
    return "the body is not a JSON object"


def install(app: FastAPI) -> None:
    @app.exception_handler(RequestValidationError)
    async def _invalid(request: Request, exc: RequestValidationError) -> JSONResponse:
        errors = []
        for e in exc.errors():
            kind = str(e.get("type", ""))
            field = field_of(e.get("loc", ()), kind)
            msg = str(e.get("msg", "invalid"))
            if kind == "json_invalid":
                ctx = e.get("ctx") or {}
                msg = f"{SEND_JSON}: not valid JSON ({ctx.get('error', 'decode error')})"
            elif kind in NOT_AN_OBJECT and tuple(e.get("loc", ())) == ("body",):
                msg = f"{SEND_JSON}: {body_problem(request, kind)}"
            if field in ("body", "") and msg.startswith("Value error, ") and ":" in msg:
                # model-level checks name the field first: "goals.0: inside obstacles.1"
                field = msg.removeprefix("Value error, ").split(":", 1)[0]
            errors.append({"field": field, "message": msg, "type": kind})
        first = errors[0] if errors else {"field": "body", "message": "invalid"}
        return problem(
            422, f"{first['field']}: {first['message']}", field=first["field"], errors=errors
        )

    @app.exception_handler(StarletteHTTPException)
    async def _http(_: Request, exc: StarletteHTTPException) -> JSONResponse:
        if exc.status_code == 400 and exc.detail == BODY_PARSE_ERROR:
            # An unreadable body (e.g. a broken form encoding) is bad input like malformed JSON.
            return problem(422, f"body: could not be parsed; {SEND_JSON}", field="body")
        detail = str(exc.detail) if exc.status_code < 500 else "internal error"
        response = problem(exc.status_code, detail, getattr(exc, "field", None))
        for key, value in (exc.headers or {}).items():
            response.headers[key] = value
        return response

    @app.exception_handler(Exception)
    async def _crash(_: Request, exc: Exception) -> JSONResponse:
        log.exception("unhandled error")
        return problem(500, f"internal error ({type(exc).__name__})")


DESCRIPTIONS = {
    401: "The API key is missing or wrong (writes, when `SCREWSNAKE_API_KEY` is set)",
    404: "No such resource (the detail names it)",
    409: "The request conflicts with the resource's state (the detail says how)",
    413: "The request body is larger than `SCREWSNAKE_MAX_BODY` (`SCREWSNAKE_MAX_MAP_BODY` for "
    "`POST /maps`; refused before it is read), or the answer would be larger than its limit "
    "(`SCREWSNAKE_MAX_PDDL_ANSWER` for a plan version's PDDL)",
    422: "Invalid request: `field` names the first field at fault, `errors` all of them",
    503: "Busy or unavailable: the queue is full or the database failed (see `Retry-After`)",
}


def responses(*codes: int) -> dict[int | str, dict[str, Any]]:
    """The error answers a route can give, for ``responses=`` (schema: ``Problem``)."""
    ref = {"$ref": "#/components/schemas/Problem"}
    return {
        code: {"description": DESCRIPTIONS[code], "content": {PROBLEM: {"schema": ref}}}
        for code in codes
    }


def document(app: FastAPI) -> None:
    """Errors are problem+json in the OpenAPI schema too: FastAPI's default 422 is replaced."""
    from fastapi.openapi.utils import get_openapi

    def openapi() -> dict[str, Any]:
        if app.openapi_schema:
            return app.openapi_schema
        schema = get_openapi(
            title=app.title,
            version=app.version,
            summary=app.summary,
            description=app.description,
            routes=app.routes,
            tags=app.openapi_tags,
        )
        ref = {"$ref": "#/components/schemas/Problem"}
        for item in schema.get("paths", {}).values():
            for op in item.values():
                answer = op.get("responses", {}).get("422")
                if answer is not None:  # FastAPI's default 422 is not what the API answers
                    answer["description"] = DESCRIPTIONS[422]
                    answer["content"] = {PROBLEM: {"schema": ref}}
        components = schema.setdefault("components", {}).setdefault("schemas", {})
        for unused in ("HTTPValidationError", "ValidationError"):
            components.pop(unused, None)
        problem_schema = Problem.model_json_schema(ref_template="#/components/schemas/{model}")
        components.update(problem_schema.pop("$defs", {}))
        components["Problem"] = problem_schema
        app.openapi_schema = schema
        return schema

    app.openapi = openapi  # type: ignore[method-assign]
