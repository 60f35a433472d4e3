"""What every race of this server shares, bundled once: settings, controllers, planner workers, controller
hosts, the database and the 3D scenes."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Protocol

from controllers.registry import ControllerSpec
from server.db import RaceDatabase
from server.hosts import ControllerHosts
from server.planning import PlannerPool
from server.settings import Settings
from sim_core.track import Track
from web.frame import RaceFrame


class Scene(Protocol):
    """A race's 3D view (``web.scene.RaceScene``): fed one frame per tick."""

    @property
    def port(self) -> int:
        """The scene server's local TCP port."""

    def update(self, frame: RaceFrame) -> None:
        """Show ``frame`` (cheap, never blocks)."""

    def close(self) -> None:
        """Stop serving (blocking)."""


SceneFactory = Callable[[Track, Sequence[tuple[str, str]], str], Scene]


@dataclass(frozen=True)
class RaceServices:
    """Started by the app's lifespan (:mod:`server.app`), handed to :class:`~server.live.LiveRaces` and from there
    to every :class:`~server.session.RaceSession`."""

    settings: Settings
    catalogue: Mapping[str, ControllerSpec]  # registered name -> spec (``human`` is not one)
    planners: PlannerPool
    hosts: ControllerHosts | None  # None: AI controllers run in threads of the server process
    db: RaceDatabase
    scene_factory: SceneFactory | None  # None: races run without a 3D view
