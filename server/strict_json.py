"""Request bodies parsed as strict JSON (RFC 8259): UTF-8, finite numbers, whole Unicode strings.

Python's :func:`json.loads` accepts ``NaN``, ``Infinity`` and ``-Infinity``, turns ``1e999`` into infinity and
``"\\ud800"`` into a lone surrogate, a string that cannot be encoded again: such values reached the models and
then the database or the 422 answer, which failed with a 500. :func:`strict_loads` refuses them all with
:class:`json.JSONDecodeError`, which FastAPI answers with a 422 ``json_invalid`` entry; routers built with
``route_class=StrictJSONRoute`` parse their bodies with it.
"""

from __future__ import annotations

import asyncio
import json
import math
import re
from collections.abc import Callable, Coroutine
from typing import Any

from fastapi import Request, Response
from fastapi.routing import APIRoute

# [bytes] bodies up to this size are parsed on the event loop (well under a millisecond); larger ones, up to
# the body limit (server.edge.BodyLimit), take a few milliseconds and are parsed in a thread, which gives the
# loop the GIL back every switch interval (server.settings.switch_interval_s)
LOOP_PARSE_BYTES = 4096

# a surrogate escape; whether it is half of a pair is decided on the parsed value, this only locates it
_SURROGATE_ESCAPE = re.compile(r"\\u[dD][89a-fA-F][0-9a-fA-F]{2}")


def _reject_constant(name: str) -> Any:
    raise ValueError(f"{name} is not JSON: numbers must be finite")


def _finite_float(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(f"{text[:40]} is out of range: numbers must be finite")
    return value


def _lone_surrogate_at(value: Any, path: tuple[str | int, ...] = ()) -> tuple[str | int, ...] | None:
    """The path of the first string (or object key) in ``value`` with a lone UTF-16 surrogate, or ``None``."""
    if isinstance(value, str):
        try:
            value.encode("utf-8")
        except UnicodeEncodeError:
            return path
        return None
    if isinstance(value, dict):
        for key, item in value.items():
            found = _lone_surrogate_at(key, (*path, "(key)")) or _lone_surrogate_at(item, (*path, key))
            if found is not None:
                return found
    elif isinstance(value, list):
        for i, item in enumerate(value):
            found = _lone_surrogate_at(item, (*path, i))
            if found is not None:
                return found
    return None


def strict_loads(body: bytes | str) -> Any:
    """Parse ``body`` as strict JSON; :class:`json.JSONDecodeError` says what is wrong and where."""
    if isinstance(body, bytes):
        try:
            text = body.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise json.JSONDecodeError("the body is not UTF-8", body.decode("utf-8", "replace"), exc.start) from None
    else:
        text = body
    try:
        # integers need no hook: Python refuses those over 4,300 digits (ValueError) and the models bound the rest
        value = json.loads(text, parse_constant=_reject_constant, parse_float=_finite_float)
    except ValueError as exc:
        if isinstance(exc, json.JSONDecodeError):
            raise
        # raised by a hook or by int(): the decoder does not say where, so point at the start
        raise json.JSONDecodeError(str(exc), text, 0) from None
    except RecursionError:
        raise json.JSONDecodeError("nested too deeply", text, 0) from None
    # only an escape can make a lone surrogate (the text is valid UTF-8): look at the value only if there is one
    where = _lone_surrogate_at(value) if _SURROGATE_ESCAPE.search(text) else None
    if where is not None:
        shown = ".".join(str(p) for p in where) or "the body"
        escape = _SURROGATE_ESCAPE.search(text)
        raise json.JSONDecodeError(
            f"lone UTF-16 surrogate in the string at {shown}", text, escape.start() if escape else 0
        )
    return value


class StrictJSONRequest(Request):
    """A request whose :meth:`json` is :func:`strict_loads`."""

    async def json(self) -> Any:
        """The body as strict JSON (parsed once; a larger body in a worker thread, off the event loop)."""
        if not hasattr(self, "_json"):
            body = await self.body()
            if len(body) > LOOP_PARSE_BYTES:
                self._json = await asyncio.to_thread(strict_loads, body)
            else:
                self._json = strict_loads(body)
        return self._json


class StrictJSONRoute(APIRoute):
    """An API route whose JSON body is parsed by :func:`strict_loads`."""

    def get_route_handler(self) -> Callable[[Request], Coroutine[Any, Any, Response]]:
        """FastAPI's handler, given a :class:`StrictJSONRequest`."""
        handler = super().get_route_handler()

        async def strict_handler(request: Request) -> Response:
            return await handler(StrictJSONRequest(request.scope, request.receive))

        return strict_handler
