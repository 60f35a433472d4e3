"""The referee's lane-change rule counted as changes happen (eqs. (10)-(11)), the original's checkpoint sampling
kept as an option, and who is at fault when karts touch (the follower; alongside, the kart that moved into the
other)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as hs

from controllers.lane_follower import LaneFollower
from sim_core import state as st
from sim_core.kart import throttle_for_acceleration
from sim_core.params import RuleParams, SimParams
from sim_core.referee import lane_with_hysteresis
from sim_core.track_io import get_track
from sim_core.world import World

OVAL_STRAIGHT_RUN = (10, 16)  # sections 10..15 of the oval are straight, 9 and 16 are curves
OVAL_CURVE_RUN = (4, 6)  # sections 4 and 5 are curves


def weave(counting: str, first_section: int, excursions: int, sections: int) -> World:
    """Drive one kart from the start of ``first_section`` for ``sections`` sections in lane 2, leaving for lane 1
    and coming back in the middle of each of the first ``excursions`` sections (so it is in lane 2 at every
    checkpoint it crosses)."""
    track = get_track("oval")
    world = World(track, 1, 1, SimParams(rules=RuleParams(lane_change_counting=counting)), sensors=False)
    lane1, lane2 = (float(v) for v in track.lane_offsets(first_section)[:2])
    start = float(track.checkpoint_s[first_section])
    world.place_kart(0, 0, start + 0.5, lane2, speed=6.0)
    follower = LaneFollower(track, world.params.kart)
    end = float(track.checkpoint_s[(first_section + sections) % track.n_checkpoints])
    for _ in range(2000):
        s = float(world.fstate[0, 0, st.F_S])
        if (s - end) % track.length < 1.0:
            break
        c = int(np.searchsorted(track.checkpoint_s, s, side="right")) - 1
        length = (
            float(track.checkpoint_s[(c + 1) % track.n_checkpoints]) - float(track.checkpoint_s[c])
        ) % track.length
        u = (s - float(track.checkpoint_s[c])) / length
        away = (c - first_section) % track.n_checkpoints < excursions and 0.05 < u < 0.45
        target = lane1 if away else lane2
        actions = follower.act_on(world, np.array([[target]]), speed_cap=6.0)
        world.step(actions)
    else:
        raise AssertionError("the weave never ended")
    return world


def test_a_weave_between_checkpoints_on_a_straight_is_counted_and_illegal_past_the_limit() -> None:
    world = weave("per_step", OVAL_STRAIGHT_RUN[0], excursions=3, sections=5)
    i = world.istate[0, 0]
    limit = world.lane_change_limit  # L = 3 on the oval
    assert limit == 3
    # 3 excursions = 6 changes on one straight: changes 4, 5 and 6 take the counter past L
    assert i[st.I_ILLEGAL_STEP] == 6 - limit
    assert i[st.I_ILLEGAL] == 6 - limit
    # at every checkpoint the kart was back in lane 2: the checkpoint rule sees nothing
    assert i[st.I_ILLEGAL_CHECKPOINT] == 0
    result = world.result(0).karts[0]
    assert result.illegal_lane_changes == result.illegal_lane_changes_per_step == 3
    assert result.illegal_lane_changes_checkpoint == 0
    assert result.safety_score == 3


def test_the_same_weave_under_the_checkpoint_option_is_not_illegal_but_still_recorded() -> None:
    world = weave("checkpoint", OVAL_STRAIGHT_RUN[0], excursions=3, sections=5)
    result = world.result(0).karts[0]
    assert result.illegal_lane_changes == 0
    assert result.safety_score == 0
    assert result.illegal_lane_changes_checkpoint == 0
    assert result.illegal_lane_changes_per_step == 3


def test_a_weave_within_the_limit_is_legal() -> None:
    world = weave("per_step", OVAL_STRAIGHT_RUN[0], excursions=1, sections=3)
    assert world.istate[0, 0, st.I_ILLEGAL_STEP] == 0
    assert world.istate[0, 0, st.I_STEP_LANE_COUNT] == 2


def test_weaving_in_curves_is_never_illegal() -> None:
    world = weave("per_step", OVAL_CURVE_RUN[0], excursions=2, sections=2)
    assert world.istate[0, 0, st.I_ILLEGAL_STEP] == 0


def test_an_unknown_counting_rule_is_refused() -> None:
    with pytest.raises(ValueError, match="lane_change_counting"):
        RuleParams(lane_change_counting="sometimes")


@settings(max_examples=200, deadline=None)
@given(wobble=hs.lists(hs.floats(-0.24, 0.24), min_size=1, max_size=50))
def test_hovering_around_a_lane_boundary_changes_nothing(wobble: list[float]) -> None:
    """Within the hysteresis band around the midpoint between two lanes, the kart stays in its lane."""
    offsets = np.array([3.5, 1.25, -1.25, -3.5])
    midpoint = 0.5 * (offsets[0] + offsets[1])
    for current in (1, 2):
        for w in wobble:
            assert lane_with_hysteresis(offsets[None, :], 0, midpoint + w, current, 0.25) == current


def test_crossing_the_hysteresis_band_changes_lane() -> None:
    offsets = np.array([3.5, 1.25, -1.25, -3.5])
    assert lane_with_hysteresis(offsets[None, :], 0, 2.375 + 0.26, 2, 0.25) == 1
    assert lane_with_hysteresis(offsets[None, :], 0, 2.375 - 0.26, 1, 0.25) == 2
    assert lane_with_hysteresis(offsets[None, :], 0, -3.0, 2, 0.25) == 4  # two lanes at once: both count


# ---------------------------------------------------------------------------------------------- faults


def side_by_side(mover: int, mover_left: bool, lead: float, both: bool = False, angle: float = 0.15) -> World:
    """Two karts alongside on the oval's straight (centres 1.3 m apart across the track, ``lead`` m apart along
    it, kart ``mover`` ahead by ``lead``); the mover (and with ``both`` the other too) heads ``angle`` rad
    toward the other. Runs until they touch."""
    track = get_track("oval")
    world = World(track, 1, 2, sensors=False)
    base = float(track.checkpoint_s[11]) + 2.0
    other = 1 - mover
    side = 1.0 if mover_left else -1.0
    world.place_kart(0, mover, base + lead, 0.65 * side, speed=8.0, heading_offset=-angle * side)
    world.place_kart(0, other, base, -0.65 * side, speed=8.0, heading_offset=angle * side if both else 0.0)
    hold = throttle_for_acceleration(world.kart_vector, 8.0, 0.0)
    for _ in range(300):
        world.step(np.tile([0.0, hold], (1, 2, 1)))
        if world.istate[0, 0, st.I_CONTACTS]:
            return world
    raise AssertionError("they never touched")


@pytest.mark.parametrize("mover", [0, 1])
@pytest.mark.parametrize("mover_left", [True, False])
@pytest.mark.parametrize("lead", [-0.6, 0.0, 0.6])
def test_alongside_the_kart_that_moved_into_the_other_is_at_fault(mover: int, mover_left: bool, lead: float) -> None:
    world = side_by_side(mover, mover_left, lead)
    faults = world.istate[0, :, st.I_FAULTS]
    assert faults[mover] == 1
    assert faults[1 - mover] == 0


@pytest.mark.parametrize("mover_left", [True, False])
def test_alongside_both_are_at_fault_when_both_moved_into_each_other(mover_left: bool) -> None:
    world = side_by_side(0, mover_left, 0.15, both=True)
    assert list(world.istate[0, :, st.I_FAULTS]) == [1, 1]


def test_alongside_rubbing_without_moving_across_is_nobodys_fault() -> None:
    world = side_by_side(0, True, 0.0, angle=0.02)  # drifting together at 0.16 m/s: under the threshold
    assert world.istate[0, 0, st.I_CONTACTS] == 1
    assert list(world.istate[0, :, st.I_FAULTS]) == [0, 0]


@pytest.mark.parametrize("follower", [0, 1])
def test_the_follower_that_runs_into_the_kart_ahead_is_at_fault(follower: int) -> None:
    track = get_track("oval")
    world = World(track, 1, 2, sensors=False)
    base = float(track.checkpoint_s[11])
    world.place_kart(0, follower, base, 1.25, speed=10.0)
    world.place_kart(0, 1 - follower, base + 3.0, 1.25, speed=4.0)
    for _ in range(100):
        world.step(np.zeros((1, 2, 2)))
        if world.istate[0, 0, st.I_CONTACTS]:
            break
    faults = world.istate[0, :, st.I_FAULTS]
    assert faults[follower] == 1 and faults[1 - follower] == 0


def test_a_follower_is_at_fault_even_when_the_leader_drifts_across_its_nose() -> None:
    """The paper's rule: not alongside, the kart behind is responsible (its front touched the other)."""
    track = get_track("oval")
    world = World(track, 1, 2, sensors=False)
    base = float(track.checkpoint_s[11])
    world.place_kart(0, 0, base, 0.0, speed=8.0)  # follower
    world.place_kart(0, 1, base + 2.3, 1.0, speed=7.0, heading_offset=-0.25)  # leader cutting across
    for _ in range(100):
        world.step(np.zeros((1, 2, 2)))
        if world.istate[0, 0, st.I_CONTACTS]:
            break
    assert world.istate[0, 0, st.I_CONTACTS] == 1
    assert list(world.istate[0, :, st.I_FAULTS]) == [1, 0]


def test_the_result_says_who_touched_whom() -> None:
    """Three karts: kart 2 runs into kart 0 from behind, kart 1 is far ahead and touches nobody. Each kart's
    ``contacts_with`` counts its contacts with each other kart, the same on both sides (team-mate contacts are
    reported apart from these)."""
    track = get_track("oval")
    world = World(track, 1, 3, sensors=False)
    base = float(track.checkpoint_s[11])
    world.place_kart(0, 2, base, 1.25, speed=10.0)  # the follower
    world.place_kart(0, 0, base + 3.0, 1.25, speed=4.0)
    world.place_kart(0, 1, base + 40.0, -1.25, speed=4.0)
    for _ in range(100):
        world.step(np.zeros((1, 3, 2)))
        if world.istate[0, 0, st.I_CONTACTS]:
            break
    karts = world.result(0).karts
    assert [k.contacts_with for k in karts] == [(0, 0, 1), (0, 0, 0), (1, 0, 0)]
    assert [k.contacts for k in karts] == [1, 0, 1]
    assert [k.collisions_at_fault for k in karts] == [0, 0, 1]
