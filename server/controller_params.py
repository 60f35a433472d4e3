"""Controller parameters in race requests: whether a request may set them, and building a controller with them.

The registry decides (:mod:`controllers.registry`): a controller's public parameters are the fields of its
parameter dataclass, with types and inclusive bounds, and ``ControllerSpec.validate`` raises
:class:`~controllers.parameters.ParameterError` naming an unknown, mistyped or out-of-bounds one. The server
turns each such error into a 422 entry at the parameter's location, and builds every driver (in this
process, a controller host or a planner worker) from the registry's picklable factory of the validated
parameters.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

from controllers.base import Controller
from controllers.parameters import ParameterError
from controllers.registry import ControllerSpec
from server.race_config import ParamValue


@dataclass(frozen=True)
class ParamProblem:
    """Why a request may not set parameter ``name``."""

    name: str
    message: str


def check_params(spec: ControllerSpec, params: Mapping[str, ParamValue]) -> list[ParamProblem]:
    """Every reason ``params`` cannot configure ``spec``'s controller (empty: they can), one per parameter."""
    problems = []
    for name, value in params.items():
        try:
            spec.validate({name: value})
        except ParameterError as exc:
            problems.append(ParamProblem(name, str(exc)))
    return problems


def resolve_factory(spec: ControllerSpec, params: Mapping[str, ParamValue]) -> Callable[[], Controller]:
    """A zero-argument, picklable factory of ``spec``'s controller with ``params`` (checked by
    :func:`check_params`), so worker processes build the very driver the request asked for."""
    return spec.factory_for(spec.validate(params))


def build_controller(factory: Callable[[], Controller]) -> Controller:
    """A new controller from a factory of :func:`resolve_factory`."""
    return factory()
