"""Public parameters of a controller, declared once on its frozen parameter dataclass (a leaf module).

Every field of the dataclass is a parameter: its name, type (``int``, ``float``, ``bool`` or ``str``) and
default come from the field; :func:`parameter` adds a description, a unit and inclusive bounds as field
metadata::

    @dataclass(frozen=True)
    class LaneFollowerParams:
        lookahead_time: float = parameter(0.45, "lookahead = speed * this", unit="s", minimum=0.0, maximum=2.0)

:func:`parameters_of` lists them (what the registry publishes, so the documentation cannot drift from the
code) and :func:`with_overrides` builds an instance from a request's values, raising :class:`ParameterError`
for an unknown name, a wrong type or a value out of bounds.
"""

from __future__ import annotations

import dataclasses
import math
import typing
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, TypeVar

METADATA_KEY = "parameter"
Value = int | float | bool | str
_TYPES: dict[object, type] = {int: int, float: float, bool: bool, str: str}
_BY_NAME = {kind.__name__: kind for kind in _TYPES.values()}
_A = {"int": "an int", "float": "a float", "bool": "a bool", "str": "a str"}

P = TypeVar("P")


@dataclass(frozen=True)
class Bounds:
    """What :func:`parameter` stores in a field's metadata."""

    description: str = ""
    unit: str = ""
    minimum: float | None = None  # inclusive
    maximum: float | None = None  # inclusive


@dataclass(frozen=True)
class Parameter:
    """One public parameter of a controller, as the registry publishes it."""

    name: str
    type: str  # "int", "float", "bool" or "str"
    default: Value
    description: str = ""
    unit: str = ""
    minimum: float | None = None  # inclusive
    maximum: float | None = None  # inclusive


class ParameterError(ValueError):
    """A parameter a request set is unknown, of the wrong type or out of bounds (an HTTP 422, not a 500)."""

    def __init__(self, controller: str, parameter: str, reason: str) -> None:
        super().__init__(f"{controller}: parameter {parameter!r} {reason}")
        self.controller = controller
        self.parameter = parameter
        self.reason = reason

    def __reduce__(self) -> tuple[type[ParameterError], tuple[str, str, str]]:
        # pickled with its fields, not its message: a race's worker process sends the error back to the runner
        return (type(self), (self.controller, self.parameter, self.reason))


class InvalidValueError(ValueError):
    """Raised by a parameter dataclass's ``__post_init__`` for a value its type and bounds allow but its meaning
    does not (an unknown name in a ``str`` parameter); :func:`with_overrides` reports it as a
    :class:`ParameterError`."""

    def __init__(self, parameter: str, reason: str) -> None:
        super().__init__(f"{parameter} {reason}")
        self.parameter = parameter
        self.reason = reason


def parameter(
    default: Value, description: str = "", *, unit: str = "", minimum: float | None = None, maximum: float | None = None
) -> Any:
    """A dataclass field with a default and the description, unit and inclusive bounds of a public parameter."""
    if minimum is not None and maximum is not None and minimum > maximum:
        raise ValueError(f"minimum {minimum} > maximum {maximum}")
    return dataclasses.field(default=default, metadata={METADATA_KEY: Bounds(description, unit, minimum, maximum)})


def parameters_of(params_type: type) -> tuple[Parameter, ...]:
    """The public parameters of the frozen dataclass ``params_type``, in field order."""
    if not dataclasses.is_dataclass(params_type):
        raise TypeError(f"{params_type!r} is not a dataclass")
    hints = typing.get_type_hints(params_type)
    out = []
    for f in dataclasses.fields(params_type):
        kind = _TYPES.get(hints[f.name])
        if kind is None:
            raise TypeError(f"{params_type.__name__}.{f.name}: a public parameter is an int, float, bool or str")
        if f.default is dataclasses.MISSING:
            raise TypeError(f"{params_type.__name__}.{f.name}: a public parameter needs a default")
        bounds = f.metadata.get(METADATA_KEY, Bounds())
        out.append(
            Parameter(f.name, kind.__name__, f.default, bounds.description, bounds.unit, bounds.minimum, bounds.maximum)
        )
    return tuple(out)


def _checked(controller: str, spec: Parameter, value: object) -> Value:
    """``value`` as the parameter's type, or :class:`ParameterError`."""
    expected = _BY_NAME[spec.type]
    # bool is an int to Python, never a number to a request; an int is a valid float
    if isinstance(value, bool) and expected is not bool:
        raise ParameterError(controller, spec.name, f"must be {_A[spec.type]}, got {value!r}")
    if expected is float and isinstance(value, int):
        value = float(value)
    if not isinstance(value, expected):
        raise ParameterError(controller, spec.name, f"must be {_A[spec.type]}, got {value!r}")
    if isinstance(value, float) and not math.isfinite(value):
        raise ParameterError(controller, spec.name, f"must be finite, got {value!r}")
    if isinstance(value, int | float) and not isinstance(value, bool):
        if spec.minimum is not None and value < spec.minimum:
            raise ParameterError(controller, spec.name, f"= {value!r} is below its minimum {spec.minimum:g}")
        if spec.maximum is not None and value > spec.maximum:
            raise ParameterError(controller, spec.name, f"= {value!r} is above its maximum {spec.maximum:g}")
    return typing.cast(Value, value)


def with_overrides(controller: str, params_type: type[P], overrides: Mapping[str, object]) -> P:
    """An instance of ``params_type`` with ``overrides`` applied to its defaults, each checked for name, type
    and bounds; :class:`ParameterError` names the first offending parameter (``controller`` names whose)."""
    specs = {p.name: p for p in parameters_of(params_type)}
    values: dict[str, Value] = {}
    for name, value in overrides.items():
        spec = specs.get(name)
        if spec is None:
            known = ", ".join(specs) or "none"
            raise ParameterError(controller, name, f"is unknown (known: {known})")
        values[name] = _checked(controller, spec, value)
    try:
        return params_type(**values)
    except InvalidValueError as exc:
        raise ParameterError(controller, exc.parameter, exc.reason) from None
