"""The RL tracker's sideways shield (:class:`~controllers.rl.sideways.SideRoomShield`, the
:class:`~controllers.rl.filters.GiveRoomAlongside` filter): its closing-speed limit against the hand-worked
formula, which karts it ignores, that it only ever steers away, and, in the simulator, that a driver steering
hard into a kart alongside is kept off it and charged nothing, where without the shield it is charged."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from controllers.base import Action, RaceContext
from controllers.rl.filters import GiveRoomAlongside
from controllers.rl.sideways import SideRoomShield
from sim_core.observation import KartView, observe
from sim_core.params import GRAVITY, SimParams, kart_preset
from sim_core.track_io import get_track
from sim_core.world import World

KART = kart_preset("paper")
TRACK = get_track("oval")
SHIELD = SideRoomShield.of(KART)
STRAIGHT_S = 5.0  # [m] on the oval's first straight


def _view(index: int, progress: float, lateral: float, speed: float, heading_offset: float = 0.0) -> KartView:
    """A kart at ``progress`` / ``lateral`` on the oval, heading along the centre line (plus an offset [rad])."""
    point, tangent = TRACK.point_at(progress)
    x, y = point + lateral * np.array([-tangent[1], tangent[0]])
    heading = math.atan2(float(tangent[1]), float(tangent[0])) + heading_offset
    return KartView(
        index, float(x), float(y), heading, speed, progress, lateral, 0.25, 1, 2, 0, 0.0, speed, 0.25, False
    )


def test_the_closing_limit_is_the_turn_away_speed_over_the_room_left() -> None:
    """None at the clearance (1.1 m centre to centre) or inside it; 2 m further out the speed from which turning
    away at 0.4 of the fresh tyres' grip (1.5 g) stops closing there: sqrt(2 * 0.4 * 1.5 g * 2)."""
    assert SHIELD.closing_limit(1.1) == 0.0
    assert SHIELD.closing_limit(0.5) == 0.0
    assert SHIELD.closing_limit(-3.1) == pytest.approx(math.sqrt(2.0 * 0.4 * 1.5 * GRAVITY * 2.0))


def test_karts_ahead_behind_far_across_or_finished_leave_the_course_free() -> None:
    me = _view(0, STRAIGHT_S + 10.0, 0.0, 12.0)
    far_ahead = _view(1, STRAIGHT_S + 14.5, 0.5, 12.0)
    far_across = _view(2, STRAIGHT_S + 10.0, 5.2, 12.0)
    finished = replace(_view(3, STRAIGHT_S + 10.0, 1.0, 12.0), finished=True)
    assert SHIELD.bounds(me, [me, far_ahead, far_across, finished], TRACK) is None
    beside = _view(4, STRAIGHT_S + 11.0, 1.5, 12.0)
    bounds = SHIELD.bounds(me, [me, beside], TRACK)
    assert bounds is not None and bounds.low == -math.inf
    assert bounds.high == pytest.approx(math.asin(SHIELD.closing_limit(1.5) / 12.0))


def test_a_kart_on_each_side_narrows_the_course_to_the_track_direction() -> None:
    """Within the clearance of both: no closing either way; further apart, room to move toward the farther one."""
    me = _view(0, STRAIGHT_S + 10.0, 0.0, 12.0)
    left, right = _view(1, STRAIGHT_S + 10.0, 1.0, 12.0), _view(2, STRAIGHT_S + 10.5, -1.0, 12.0)
    bounds = SHIELD.bounds(me, [me, left, right], TRACK)
    assert bounds is not None and (bounds.low, bounds.high) == (0.0, 0.0)
    far_left = _view(1, STRAIGHT_S + 10.0, 2.5, 12.0)
    bounds = SHIELD.bounds(me, [me, far_left, right], TRACK)
    assert bounds is not None and bounds.low == 0.0
    assert bounds.high == pytest.approx(math.asin(SHIELD.closing_limit(2.5) / 12.0))


@given(
    steer=st.floats(-1.0, 1.0),
    throttle=st.floats(-1.0, 1.0),
    speed=st.floats(0.0, 15.0),
    across=st.floats(-4.0, 4.0).filter(lambda a: abs(a) > 0.05),
    along=st.floats(-3.0, 3.0),
    drift=st.floats(-0.4, 0.4),
)
def test_it_only_ever_steers_away_from_the_kart_alongside(
    steer: float, throttle: float, speed: float, across: float, along: float, drift: float
) -> None:
    """The pedal is the policy's; the steer is the policy's or one turning further away from the other kart."""
    me = _view(0, STRAIGHT_S + 10.0, 0.0, speed, heading_offset=drift)
    other = _view(1, STRAIGHT_S + 10.0 + along, across, 12.0)
    bounds = SHIELD.bounds(me, [me, other], TRACK)
    out = (
        Action(steer, throttle)
        if bounds is None
        else SHIELD.steer.limit(Action(steer, throttle), me, me.heading, bounds, TRACK)
    )
    assert out.throttle == throttle
    assert -1.0 <= out.steer <= 1.0
    if across > 0.0:  # on the left: never more to the left than the policy asked
        assert out.steer <= steer + 1e-12
    else:
        assert out.steer >= steer - 1e-12


def _side_by_side(shielded: bool, steer: float = 0.6) -> tuple[int, float]:
    """Two karts side by side at 10 m/s on the oval's straight, 1.8 m apart; kart 0 steers ``steer`` toward kart
    1 (on its left) for 2 s, through the shield's filter (every 40 ms, as the RL tracker decides) when
    ``shielded``; kart 1 holds its line. Returns kart 0's collisions at fault and the closest gap across [m]."""
    world = World(TRACK, 1, 2, SimParams(kart=KART))
    world.reset(start_lanes=[2, 3])
    world.place_kart(0, 0, s=STRAIGHT_S, d=-0.9, speed=10.0)
    world.place_kart(0, 1, s=STRAIGHT_S, d=0.9, speed=10.0)
    world.sense(0)
    give_room = GiveRoomAlongside()
    give_room.reset(RaceContext(TRACK, KART, 0, 2, world.lane_change_limit, 0))
    action = Action(steer, 0.3)
    closest = math.inf
    for step in range(100):
        if step % 2 == 0:
            observation = observe(world, 0)[0]
            action = give_room.apply(Action(steer, 0.3), observation) if shielded else Action(steer, 0.3)
        world.step(np.array([[[action.steer, action.throttle], [0.0, 0.3]]]))
        lateral = observe(world, 0)[0].karts
        closest = min(closest, lateral[1].lateral - lateral[0].lateral)
    return world.result(0).karts[0].collisions_at_fault, closest


def test_a_driver_steering_into_a_kart_alongside_is_kept_off_it() -> None:
    """Unshielded, the steer drives kart 0 into kart 1 and the referee charges it; shielded, it closes to no
    nearer than the 0.9 m body width and is charged nothing."""
    faults, closest = _side_by_side(shielded=False)
    assert faults >= 1 and closest < 0.95
    faults, closest = _side_by_side(shielded=True)
    assert faults == 0
    assert closest > 0.9
