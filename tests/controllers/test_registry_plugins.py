"""Controllers registered from code (controllers.registry.register): built by name like the built-in ones,
never under a taken name, and the registry stays read-only from outside."""

from __future__ import annotations

from collections.abc import Iterator

import pytest

from controllers import registry
from controllers.base import Action, Controller, RaceContext
from controllers.registry import REGISTRY, ControllerSpec, controller_names, make_controller, register
from sim_core.observation import Observation

NAME = "test-plugin-coaster"


class Coaster:
    """The smallest driver: straight ahead at a quarter throttle."""

    name = NAME
    rate_hz = 10.0

    def reset(self, context: RaceContext) -> None:
        """Nothing to prepare."""

    def act(self, observation: Observation) -> Action:
        """Straight ahead, gently."""
        return Action(0.0, 0.25)


@pytest.fixture
def plugin() -> Iterator[ControllerSpec]:
    spec = ControllerSpec(name=NAME, description="straight ahead at a quarter throttle", factory=Coaster)
    register(spec)
    try:
        yield spec
    finally:
        registry._BY_NAME.pop(NAME, None)  # other tests list the built-in controllers


def test_a_registered_controller_is_built_by_name(plugin: ControllerSpec) -> None:
    assert NAME in controller_names() and REGISTRY[NAME] is plugin
    driver = make_controller(NAME)
    assert isinstance(driver, Coaster) and isinstance(driver, Controller)


def test_a_taken_name_is_refused(plugin: ControllerSpec) -> None:
    with pytest.raises(ValueError, match="already registered"):
        register(plugin)
    with pytest.raises(ValueError, match="already registered"):
        register(ControllerSpec(name="mcts-lqng", description="an impostor", factory=Coaster))
    assert REGISTRY["mcts-lqng"].factory is not Coaster


def test_the_registry_mapping_is_read_only() -> None:
    with pytest.raises(TypeError):
        REGISTRY[NAME] = REGISTRY["lane-follower"]  # type: ignore[index]
