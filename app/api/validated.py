"""Routes whose JSON body is validated off the event loop (``app.service.validation``).

FastAPI validates a body on the event loop; a costly one stalls every other request. Routers
made with ``route_class=ValidatedRoute`` keep their signatures (so the OpenAPI schema and the
422 answers are what they were) while the body is parsed and validated in a validation process.
"""

from __future__ import annotations

import email.message
from collections.abc import Callable, Coroutine
from typing import Any

from fastapi import Request, Response
from fastapi.exceptions import RequestValidationError
from fastapi.routing import APIRoute
from pydantic import BaseModel
from starlette.concurrency import run_in_threadpool
from starlette.exceptions import HTTPException

from app.api.errors import BODY_PARSE_ERROR
from app.service.maps import stored_maps
from app.service.validation import Invalid, NeedsMaps, Unparsable, Validation


def is_json(content_type: str | None) -> bool:
    """Whether FastAPI parses a body of this content type as JSON (it needs one: a body
    without ``Content-Type`` is not JSON to it)."""
    if not content_type:
        return False
    message = email.message.Message()
    message["content-type"] = content_type
    if message.get_content_maintype() != "application":
        return False
    subtype = message.get_content_subtype()
    return subtype == "json" or subtype.endswith("+json")


def body_model(route: APIRoute) -> type[BaseModel] | None:
    """The pydantic model a route's body is, if it is one (a single, not embedded body)."""
    field = route.body_field
    if field is None or len(route.dependant.body_params) != 1:
        return None
    annotation = field.field_info.annotation
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    return None


class ValidatedRoute(APIRoute):
    """A route whose JSON body is validated in the validation pool (``app.state.services.
    validation``), never on the event loop. FastAPI then gets the validated instance where it
    would have parsed the JSON, and takes it as it is; anything else (no body, another
    content type) goes to FastAPI unchanged, which answers it as before."""

    def get_route_handler(self) -> Callable[[Request], Coroutine[Any, Any, Response]]:
        handler = super().get_route_handler()
        model = body_model(self)
        if model is None:
            return handler

        async def validated(request: Request) -> Response:
            body = await request.body()
            if body and is_json(request.headers.get("content-type")):
                services = request.app.state.services
                validation: Validation = services.validation
                result = await validation.body(model, body)
                if isinstance(result, NeedsMaps):  # a mission naming stored maps: with them
                    found = await run_in_threadpool(stored_maps, services.store, result.ids)
                    again = await validation.body(model, body, {"maps": found})
                    if isinstance(again, NeedsMaps):  # (cannot be: the context holds maps)
                        raise HTTPException(503, "maps could not be read")
                    result = again
                if isinstance(result, Invalid):  # FastAPI's own errors: the same 422
                    raise RequestValidationError(result.errors)
                if isinstance(result, Unparsable):  # FastAPI's 400 (our 422, field "body")
                    raise HTTPException(400, BODY_PARSE_ERROR)
                # FastAPI's ``await request.json()`` answers this instead of parsing again.
                request._json = result
            return await handler(request)

        return validated
