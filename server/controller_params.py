"""Controller parameters in race requests: whether a request may set them, and building a controller with them.

This is the one place the server decides that; it asks the registry (:mod:`controllers.registry`) what it
exposes today, which is each controller's parameter names with their defaults as text
(``ControllerSpec.parameters``) and a factory. The rules, until the registry offers its own validator and a
way to build a controller from parameters (then :func:`check_params` and :func:`build_controller` call those):

* a name must be one of the controller's parameters;
* the value has the type of the default: an integer default takes integers, a decimal one any number, ``true`` /
  ``false`` booleans, anything else text;
* numbers must be finite and greater than zero (every numeric parameter registered today is a rate, a count, a
  horizon or a margin);
* the controller's factory must accept the parameter as a keyword argument; a registered controller whose
  factory does not yet cannot have it set (rather than silently racing with the default).
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass

from controllers.base import Controller
from controllers.registry import ControllerSpec
from server.race_config import ParamValue


@dataclass(frozen=True)
class ParamProblem:
    """Why a request may not set parameter ``name``."""

    name: str
    message: str


def _kind(default: str) -> type:
    """The type a parameter takes, from the text of its default."""
    if default.strip().lower() in ("true", "false"):
        return bool
    for kind in (int, float):
        try:
            kind(default)
        except ValueError:
            continue
        return kind
    return str


def _check_value(spec: ControllerSpec, name: str, value: ParamValue) -> str | None:
    kind = _kind(spec.parameters[name])
    what = f"{spec.name} parameter {name!r}"
    if kind is bool:
        return None if isinstance(value, bool) else f"{what} takes true or false, got {value!r}"
    if kind is str:
        return None if isinstance(value, str) else f"{what} takes text, got {value!r}"
    if isinstance(value, bool) or not isinstance(value, int | float) or (kind is int and isinstance(value, float)):
        return f"{what} takes {'an integer' if kind is int else 'a number'}, got {value!r}"
    if not math.isfinite(value) or value <= 0:
        return f"{what} must be greater than 0, got {value!r}"
    return None


def _accepts(factory: Callable[..., Controller], name: str) -> bool:
    try:
        inspect.signature(factory).bind_partial(**{name: None})
    except (TypeError, ValueError):
        return False
    return True


def check_params(spec: ControllerSpec, params: Mapping[str, ParamValue]) -> list[ParamProblem]:
    """Every reason ``params`` cannot configure ``spec``'s controller (empty: they can)."""
    problems = []
    for name, value in params.items():
        if name not in spec.parameters:
            known = sorted(spec.parameters)
            problems.append(ParamProblem(name, f"unknown {spec.name} parameter {name!r}; known: {known}"))
        elif (message := _check_value(spec, name, value)) is not None:
            problems.append(ParamProblem(name, message))
        elif not _accepts(spec.factory, name):
            message = f"{spec.name} parameter {name!r} cannot be set yet: the registry builds it with its default"
            problems.append(ParamProblem(name, message))
    return problems


def build_controller(factory: Callable[..., Controller], params: Mapping[str, ParamValue]) -> Controller:
    """A new controller from its registered factory with ``params`` (checked by :func:`check_params`)."""
    return factory(**params) if params else factory()
