"""The racing rules of the paper in one place: the lane-change counter, collision responsibility and the
safety buffers. Compiled so the referee (and the planners' discrete game) call the very same code."""

from __future__ import annotations

from numba import njit


@njit(cache=True)
def lane_change_update(
    count: int, previous_lane: int, lane: int, driven_straight: bool, next_straight: bool, limit: int
) -> tuple[int, bool]:
    """One update of the lane-change rule: returns (new counter, illegal).

    eq. (10) gen_lane_var: the counter adds the number of lanes crossed (``|lane - previous_lane|``) and resets
    to 0 whenever the road type changes (the stretch just driven is straight and the next one a curve, or the
    reverse); eq. (11) gen_lane_lim: a change is illegal when it was made on a straight (``driven_straight``)
    and takes the counter past ``limit`` (L). A step without a lane change is never illegal (the original
    charged again at every checkpoint while the counter stayed above L).

    The referee calls it every step with the lane the kart is in (lane membership with hysteresis), which is
    the paper's rule, and also at every checkpoint crossing with the lane there, which is the original
    implementation's sampling (behind the paper's tables); the discrete game calls it per checkpoint.
    """
    crossed = abs(lane - previous_lane)
    illegal = driven_straight and crossed > 0 and count + crossed > limit
    if driven_straight != next_straight:
        return 0, illegal
    return count + crossed, illegal


@njit(cache=True, inline="always")
def front_touches(contact_param: float, toward_other_dot_heading: float, cone_cos: float) -> bool:
    """Whether a kart's front touches another: the contact point is on the front half of its body axis
    (``contact_param`` >= 0.5, 0 = rear end, 1 = front end) and the other kart lies within the frontal cone
    (the unit direction toward the contact, dotted with the heading, is at least ``cone_cos``).

    This is the paper's responsibility rule: the follower (the kart whose nose runs into the other) is at
    fault; side-by-side rubbing and being hit from behind are not.
    """
    return contact_param >= 0.5 and toward_other_dot_heading >= cone_cos


@njit(cache=True, inline="always")
def required_buffer(directly_behind: bool, buffer_side: float, buffer_behind: float) -> float:
    """eqs. (8)-(9) gen_coll_avoid: the nose-to-body distance a kart must keep: s1 when directly behind the
    other, else s0."""
    return buffer_behind if directly_behind else buffer_side


def safety_score(collisions_at_fault: int, illegal_lane_changes: int) -> int:
    """The paper's safety score of one kart in one race (section 5.2.2): collisions at fault plus illegal lane
    changes (lower is safer)."""
    return collisions_at_fault + illegal_lane_changes


def race_winner(finish_times: list[float | None]) -> int | None:
    """The winner: the kart with the earliest finish (the lower index on a tie); nobody when nobody finished
    (a DNF never wins)."""
    finishers = [(t, k) for k, t in enumerate(finish_times) if t is not None]
    return min(finishers)[1] if finishers else None
