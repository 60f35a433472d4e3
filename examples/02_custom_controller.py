"""A controller of your own: write a class with the Controller Protocol's four members, register it, race it.

From the repo root::

    .venv/bin/python examples/02_custom_controller.py                       # vs the lane follower on the oval
    .venv/bin/python examples/02_custom_controller.py --opponent fixed-lqng --track complex --laps 1

A driver needs ``name``, ``rate_hz`` (decisions per second; the world holds the last action in between),
``reset(context)`` once per race and ``act(observation) -> Action`` per decision
(:class:`controllers.base.Controller`). It sees what every driver sees (:class:`sim_core.observation.Observation`:
every kart's pose, progress, lane and counters, plus its own 9 range rays) and knows the track and its kart
from the :class:`~controllers.base.RaceContext`. Races name drivers by registered name, never by Python path:
:func:`controllers.registry.register` adds one to this process's registry, after which headless races
(``run_race``) and everything else that builds drivers by name can use it.
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from controllers.base import Action, Controller, RaceContext
from controllers.race import RaceSpec, run_race
from controllers.registry import ControllerSpec, register
from sim_core.observation import Observation
from sim_core.params import KartParams
from sim_core.state import HIT_KART
from sim_core.track import Track

LOOKAHEAD = 6.0  # [m] along the centre line to the aim point
PREVIEW = 20.0  # [m] along the centre line over which it measures how much the road turns
STEER_GAIN = 1.5  # steer input per radian of heading error
GRIP_USE = 0.8  # [-] fraction of the kart's lateral limit it plans to use in bends
GAP = 6.0  # [m] a kart closer than this straight ahead (ray 0) makes it slow down


class RayCruiser:
    """Pure pursuit on the lane it starts in, at the speed its tyres allow for the bend ahead, backing off when
    its forward ray sees a kart close ahead (the kart behind is the one responsible for not hitting it)."""

    name = "ray-cruiser"
    rate_hz = 25.0

    def __init__(self) -> None:
        self._track: Track | None = None
        self._kart: KartParams | None = None
        self._lateral = 0.0

    def reset(self, context: RaceContext) -> None:
        """Remember the track and the kart's limits; the lane is taken from the first observation."""
        self._track = context.track
        self._kart = context.kart
        self._lateral = math.nan

    def act(self, observation: Observation) -> Action:
        """Steer toward the aim point on its lane; throttle toward a speed for the road and traffic ahead."""
        assert self._track is not None and self._kart is not None, "reset() first"
        me = observation.me
        if math.isnan(self._lateral):
            self._lateral = me.lateral
        point, tangent = self._track.point_at(me.progress + LOOKAHEAD)
        aim = point + self._lateral * np.array([-tangent[1], tangent[0]])  # left normal times the offset
        error = math.atan2(aim[1] - me.y, aim[0] - me.x) - me.heading
        error = (error + math.pi) % (2.0 * math.pi) - math.pi
        steer = max(-1.0, min(1.0, STEER_GAIN * error))

        # the road's mean curvature over the preview, and the speed the tyres hold on it at their wear
        _, far = self._track.point_at(me.progress + LOOKAHEAD + PREVIEW)
        turn = abs(math.atan2(tangent[0] * far[1] - tangent[1] * far[0], float(tangent @ far)))
        grip = GRIP_USE * float(self._kart.lateral_limit(me.wear))
        target = min(self._kart.top_speed, math.sqrt(grip * PREVIEW / max(turn, 1e-6)))
        if observation.ray_hits[0] == HIT_KART and observation.ray_distances[0] < GAP:
            target = min(target, 0.8 * me.speed)
        throttle = max(-1.0, min(1.0, 0.6 * (target - me.speed)))
        return Action(steer, throttle)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--track", default="oval")
    parser.add_argument("--laps", type=int, default=None, help="laps (default: the track's)")
    parser.add_argument("--opponent", default="lane-follower", help="a registered controller")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()

    assert isinstance(RayCruiser(), Controller)  # the Protocol is structural: no base class needed
    register(
        ControllerSpec(
            name=RayCruiser.name,
            description="Pure pursuit on its start lane; backs off when its forward ray sees a kart (an example).",
            factory=RayCruiser,
        )
    )
    spec = RaceSpec(track=args.track, controllers=(RayCruiser.name, args.opponent), laps=args.laps, seed=args.seed)
    outcome = run_race(spec)
    result = outcome.result
    print(f"{spec.track}: {result.duration:.2f} s of racing simulated in {outcome.wall_seconds:.2f} s")
    for kart in sorted(result.karts, key=lambda k: k.position):
        finish = f"{kart.finish_time:7.2f} s" if kart.finish_time is not None else "    DNF"
        print(
            f"  {kart.position}. {spec.controllers[kart.kart]:<14} {finish}  laps {kart.laps_completed}, "
            f"collisions at fault {kart.collisions_at_fault}, wall hits {kart.wall_hits}"
        )
    winner = result.winner
    print(f"winner: {'nobody' if winner is None else spec.controllers[winner]}")


if __name__ == "__main__":
    main()
