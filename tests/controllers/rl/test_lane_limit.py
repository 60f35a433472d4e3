"""The RL tracker's lane-limit shield (:class:`~controllers.rl.sideways.LaneLimitShield`, the
:class:`~controllers.rl.filters.KeepToLaneLimit` filter): the band of offsets it allows against the referee's lane
geometry worked by hand, where it has nothing to say, that it only ever steers back from the band's edge, and, in
the simulator, that a driver steering across the lanes after spending a straight's changes is kept from another
change, where without the shield the referee counts it illegal."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from controllers.base import Action, RaceContext
from controllers.rl.filters import KeepToLaneLimit
from controllers.rl.sideways import LaneLimitShield
from sim_core import state as kart_state
from sim_core.observation import KartView, observe
from sim_core.params import RuleParams, SimParams, kart_preset
from sim_core.track_io import get_track
from sim_core.world import World

KART = kart_preset("paper")
TRACK = get_track("oval")
LIMIT = 3
SHIELD = LaneLimitShield.of(KART, TRACK, LIMIT)
STRAIGHT_S = 5.0  # [m] on the oval's first straight
SLACK = RuleParams().lane_hysteresis - 0.15  # [m] past the midpoint the kart may go: the hysteresis less the margin


def _view(
    progress: float, lateral: float, speed: float, lane: int, changes: int, heading_offset: float = 0.0
) -> KartView:
    """A kart at ``progress`` / ``lateral`` on the oval in ``lane``, ``changes`` lane changes into the stretch."""
    point, tangent = TRACK.point_at(progress)
    x, y = point + lateral * np.array([-tangent[1], tangent[0]])
    heading = math.atan2(float(tangent[1]), float(tangent[0])) + heading_offset
    passed = int(np.searchsorted(TRACK.checkpoint_s, progress, side="right")) - 1
    return KartView(
        0,
        float(x),
        float(y),
        heading,
        speed,
        progress,
        lateral,
        0.25,
        passed,
        lane,
        0,
        0.0,
        speed,
        0.25,
        False,
        lane,
        changes,
    )


def _midpoints(progress: float) -> np.ndarray:
    """The midpoints between neighbouring lanes at ``progress`` (lane 1 leftmost), from the referee's table."""
    row = int(np.searchsorted(TRACK.centre_s, progress, side="right")) - 1
    offsets = TRACK.sample_lane_offsets()[row]
    return 0.5 * (offsets[:-1] + offsets[1:])


def test_with_the_changes_spent_the_band_is_the_kart_s_lane_and_the_hysteresis() -> None:
    mid = _midpoints(STRAIGHT_S)
    low, high = SHIELD.band(_view(STRAIGHT_S, 0.0, 10.0, lane=2, changes=LIMIT), TRACK)  # type: ignore[misc]
    assert high == pytest.approx(mid[0] + SLACK)  # lane 1 | lane 2
    assert low == pytest.approx(mid[1] - SLACK)  # lane 2 | lane 3


def test_one_change_left_reaches_the_next_lanes_and_a_lane_on_the_edge_opens_its_side() -> None:
    mid = _midpoints(STRAIGHT_S)
    band = SHIELD.band(_view(STRAIGHT_S, 0.0, 10.0, lane=3, changes=LIMIT - 1), TRACK)
    assert len(TRACK.lane_offsets(0)) == 4
    assert band is not None and band[0] == -math.inf and band[1] == pytest.approx(mid[0] + SLACK)  # lanes 2-4
    assert SHIELD.band(_view(STRAIGHT_S, 0.0, 10.0, lane=3, changes=0), TRACK) is None  # every lane within reach


def test_a_curve_or_an_unknown_lane_leaves_the_course_free() -> None:
    curve = float(TRACK.checkpoint_s[next(c for c in range(TRACK.n_checkpoints) if not TRACK.section_is_straight(c))])
    assert SHIELD.band(_view(curve + 1.0, 0.0, 10.0, lane=2, changes=LIMIT), TRACK) is None
    assert SHIELD.band(_view(STRAIGHT_S, 0.0, 10.0, lane=0, changes=LIMIT), TRACK) is None


@given(
    steer=st.floats(-1.0, 1.0), speed=st.floats(1.0, 15.0), lateral=st.floats(-1.5, 1.5), lane=st.sampled_from([2, 3])
)
def test_it_only_ever_steers_back_from_the_edge_the_policy_steers_for(
    steer: float, speed: float, lateral: float, lane: int
) -> None:
    """A kart within its band on the straight, heading along it, with its changes spent: the steer is the policy's
    or one turning less toward the side the policy steers for; the pedal is always the policy's."""
    me = _view(STRAIGHT_S + 10.0, lateral, speed, lane=lane, changes=LIMIT)
    low, high = SHIELD.band(me, TRACK)  # type: ignore[misc]
    if not low < lateral < high:
        return
    bounds = SHIELD.bounds(me, TRACK)
    assert bounds is not None and bounds.low < 0.0 < bounds.high
    out = SHIELD.steer.limit(Action(steer, 0.4), me, me.heading, bounds, TRACK)
    assert out.throttle == 0.4
    assert (0.0 <= out.steer <= steer) if steer >= 0.0 else (steer <= out.steer <= 0.0)


def _across_the_lanes(shielded: bool, steer: float, speed: float) -> tuple[int, int]:
    """A kart at ``speed`` [m/s] in lane 2 on the oval's straight with the straight's changes spent steers ``steer`` for
    2 s, through the filter (every 40 ms, as the RL tracker decides) when ``shielded``. Returns the illegal lane
    changes the referee counted and the lane it ends in."""
    world = World(TRACK, 1, 1, SimParams(kart=KART))
    world.reset(start_lanes=[2])
    world.place_kart(0, 0, s=STRAIGHT_S, d=float(TRACK.lane_offsets(0)[1]), speed=speed)
    world.istate[0, 0, kart_state.I_LANE_NOW] = 2
    world.istate[0, 0, kart_state.I_STEP_LANE_COUNT] = world.lane_change_limit
    world.sense(0)
    keep = KeepToLaneLimit()
    keep.reset(RaceContext(TRACK, KART, 0, 1, world.lane_change_limit, 0))
    action = Action(steer, 0.3)
    for step in range(100):
        if step % 2 == 0:
            observation = observe(world, 0)[0]
            action = keep.apply(Action(steer, 0.3), observation) if shielded else Action(steer, 0.3)
        world.step(np.array([[[action.steer, action.throttle]]]))
    assert TRACK.section_is_straight(int(world.istate[0, 0, kart_state.I_CP_PASSED]))  # still on the straight
    return int(world.istate[0, 0, kart_state.I_ILLEGAL_STEP]), int(world.istate[0, 0, kart_state.I_LANE_NOW])


@pytest.mark.parametrize("speed", [6.0, 14.0])
@pytest.mark.parametrize("steer", [0.15, 0.6, 1.0, -0.3, -1.0])
def test_a_driver_steering_across_the_lanes_with_its_changes_spent_keeps_its_lane(steer: float, speed: float) -> None:
    """Unshielded, the steer takes the kart into the next lane and the referee counts the change illegal;
    shielded, it stays in lane 2 and nothing is counted."""
    illegal, lane = _across_the_lanes(shielded=False, steer=steer, speed=speed)
    assert illegal >= 1 and lane != 2
    assert _across_the_lanes(shielded=True, steer=steer, speed=speed) == (0, 2)
