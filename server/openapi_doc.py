"""The OpenAPI schema, made to say the truth about this server.

FastAPI derives the schema from the request models, which cannot know this server's tracks, controllers,
controller parameters or settings: alone it would call valid bodies that the routes then refuse (an unknown
track, a parameter another controller has, ``start_lanes`` of another length than ``karts``). :func:`truthful_openapi`
adds what only the running server knows, so that a body valid under the schema is accepted (or refused only for
the server's state: 409, 429), and documents the answers the edge gives to any operation (:mod:`server.edge`:
400, 403, 413). It also links a created race to the operations on it (OpenAPI links: create -> get, stop,
result, replay, ticks).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

from fastapi import FastAPI

from controllers.parameters import Parameter
from controllers.registry import ControllerSpec, controller_names
from server.limits import MAX_KARTS, MAX_PARAM_TEXT
from server.models import ErrorOut
from server.race_config import HUMAN
from server.routes.tournaments import RESERVED_IDS
from server.settings import Settings

JSONObject = dict[str, Any]
_ERROR_REF = {"$ref": "#/components/schemas/ErrorOut"}
_JSON_TYPES = {"int": "integer", "float": "number", "bool": "boolean", "str": "string"}


def _error(description: str) -> JSONObject:
    return {"description": description, "content": {"application/json": {"schema": _ERROR_REF}}}


def _edge_responses(settings: Settings) -> dict[str, JSONObject]:
    return {
        "400": _error("the Host header names no host served here (allowed_hosts)"),
        "403": _error("the request comes from a page of a site not allowed (allowed_origins)"),
        "413": _error(f"the request body is over {settings.max_body_bytes} bytes (max_body_bytes)"),
    }


def _document_edge(schema: JSONObject, settings: Settings) -> None:
    schema.setdefault("components", {}).setdefault("schemas", {}).setdefault(
        "ErrorOut", ErrorOut.model_json_schema(ref_template="#/components/schemas/{model}")
    )
    for operations in schema.get("paths", {}).values():
        for operation in operations.values():
            responses = operation.setdefault("responses", {})
            for code, response in _edge_responses(settings).items():
                responses.setdefault(code, response)


def _document_api_key(schema: JSONObject, settings: Settings) -> None:
    """Without an API key set, no operation needs one: the schema says so (the 401 answers stay documented)."""
    if settings.api_key is not None:
        return
    for operations in schema.get("paths", {}).values():
        for operation in operations.values():
            operation.pop("security", None)


def _parameter_schema(parameter: Parameter) -> JSONObject:
    out: JSONObject = {"type": _JSON_TYPES[parameter.type], "description": parameter.description}
    if parameter.type in ("int", "float"):
        if parameter.minimum is not None:
            out["minimum"] = parameter.minimum
        if parameter.maximum is not None:
            out["maximum"] = parameter.maximum
    if parameter.type == "str":
        out["maxLength"] = MAX_PARAM_TEXT
    return out


def _kart_schema(name: str, spec: ControllerSpec[Any] | None, kart: JSONObject) -> JSONObject:
    """``KartIn`` for one controller: its name, and only its parameters with their types and bounds."""
    parameters = spec.parameter_list if spec is not None else ()
    params: JSONObject = {
        "type": "object",
        "properties": {p.name: _parameter_schema(p) for p in parameters},
        "additionalProperties": False,
    }
    return {
        "type": "object",
        "title": f"KartIn ({name})",
        "properties": {**kart["properties"], "controller": {"type": "string", "enum": [name]}, "params": params},
        "required": ["controller"],
        "additionalProperties": False,
    }


def _describe_choices(
    schema: JSONObject, settings: Settings, catalogue: Mapping[str, ControllerSpec[Any]], tracks: list[str]
) -> None:
    schemas = schema["components"]["schemas"]
    kart = schemas["KartIn"]
    variants = [_kart_schema(name, catalogue[name], kart) for name in sorted(catalogue)]
    variants.append(_kart_schema(HUMAN, None, kart))
    schemas["KartIn"] = {"title": "KartIn", "description": kart.get("description", ""), "oneOf": variants}

    race = schemas["RaceIn"]
    race["properties"]["track"]["enum"] = tracks
    race["properties"]["laps"]["anyOf"][0]["maximum"] = settings.max_laps
    # as many start lanes as karts: one branch per number of karts
    race["anyOf"] = [
        {
            "properties": {
                "karts": {"minItems": n, "maxItems": n},
                "start_lanes": {"anyOf": [{"type": "null"}, {"type": "array", "minItems": n, "maxItems": n}]},
            }
        }
        for n in range(1, MAX_KARTS + 1)
    ]

    tournament = schemas["TournamentIn"]
    agents = tournament["properties"]["agents"]
    agents["items"]["enum"] = controller_names()
    agents["uniqueItems"] = True
    tournament["properties"]["tracks"]["items"]["enum"] = tracks
    tournament_id = tournament["properties"]["id"]
    tournament_id["not"] = {"enum": sorted(RESERVED_IDS)}


def _operation_ids(schema: JSONObject) -> dict[tuple[str, str], str]:
    return {
        (method.upper(), path): operation["operationId"]
        for path, operations in schema.get("paths", {}).items()
        for method, operation in operations.items()
        if "operationId" in operation
    }


def _link_races(schema: JSONObject) -> None:
    ids = _operation_ids(schema)
    race_id = {"race_id": "$response.body#/id"}
    targets = {
        "GetRace": ("GET", "/api/races/{race_id}"),
        "StopRace": ("POST", "/api/races/{race_id}/stop"),
        "GetResult": ("GET", "/api/races/{race_id}/result"),
        "GetReplay": ("GET", "/api/races/{race_id}/replay"),
        "GetTicks": ("GET", "/api/races/{race_id}/ticks"),
    }
    links = {name: {"operationId": ids[target], "parameters": race_id} for name, target in targets.items()}
    created = schema["paths"]["/api/races"]["post"]["responses"]["201"]
    created["links"] = links
    stopped = schema["paths"]["/api/races/{race_id}/stop"]["post"]["responses"]["200"]
    stopped["links"] = {name: links[name] for name in ("GetRace", "GetResult", "GetReplay")}


def truthful_openapi(
    app: FastAPI, settings: Settings, catalogue: Mapping[str, ControllerSpec[Any]], tracks: Callable[[], list[str]]
) -> None:
    """Make ``app.openapi()`` the schema FastAPI derives, completed as the module docstring says."""
    derive = app.openapi

    def openapi() -> JSONObject:
        if app.openapi_schema is None:
            schema = derive()
            _document_edge(schema, settings)
            _document_api_key(schema, settings)
            _describe_choices(schema, settings, catalogue, tracks())
            _link_races(schema)
            app.openapi_schema = schema
        return app.openapi_schema

    app.openapi = openapi  # type: ignore[method-assign]
