"""Plans: the waypoints a high-level planner hands to a tracker (a leaf module every layer may import)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Waypoint:
    """A planned (or predicted) pass of one kart through a checkpoint."""

    checkpoint: int  # absolute checkpoint index
    lane: int  # 1-based
    position: tuple[float, float]  # [m] the lane point
    speed: float  # [m/s] target speed (top of the planned velocity bin)
    time: float  # [s] predicted arrival, relative to the root's leader


@dataclass(frozen=True)
class Plan:
    """The planner's answer: ego waypoints and every other player's predicted waypoints."""

    ego: int
    root_checkpoint: int
    waypoints: dict[int, tuple[Waypoint, ...]]  # kart index -> waypoints in checkpoint order
    iterations: int
    nodes: int
    seconds: float  # [s] wall time of the search
    padded: int = 0  # trailing ego waypoints the search did not reach (the ego holds its lane there): not planned

    @property
    def ego_waypoints(self) -> tuple[Waypoint, ...]:
        """The ego kart's waypoints."""
        return self.waypoints.get(self.ego, ())

    def opponent_waypoints(self) -> dict[int, tuple[Waypoint, ...]]:
        """Predicted waypoints of the other players."""
        return {k: w for k, w in self.waypoints.items() if k != self.ego}
