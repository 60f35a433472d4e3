"""The LQNG tracker as each registered hierarchical agent drives it: tracker settings and a tuple of traffic rules
(:mod:`controllers.lq.traffic`) that reads like a description of the driver.

``mcts-lqng`` (ours, beyond the paper's tracker): the game's speed bins are coarse, so planned speeds are a ceiling
3 m/s above the bin and the racing line's speed profile binds. In traffic it drives its planned lanes exactly with a
kart alongside or a pass under way, keeps inside the lanes its lane changes reach, keeps 1.5 m sideways from a kart
alongside, keeps station by Gipps' safe speed (2.3 m behind on straights, 3.0 m in curves: it follows 3.0 m behind
at 14 m/s on a straight and dives inside at the straight's end), lets a kart 2 m/s faster cut in, and steers at most
5/s. ``fixed-lqng``: the original's heading weight and avoidance scale with the fixed line (1.9, 0.45), a stronger
denial, the line's own lanes followed to within 1.25 m in traffic as well, under mcts-lqng's rules of the road
(the paper's Fixed-LQNG has none: behind two slower karts abreast its game ran into one).
"""

from __future__ import annotations

from dataclasses import replace

from controllers.lq.tracker import LQNGParams, LQNGTracker, LQNGWeights
from controllers.lq.traffic import (
    AlongsideDiscipline,
    LaneRuleGuard,
    LanesExactAlongside,
    PassDetector,
    StationKeeping,
    SteerRateLimit,
    TrafficRule,
    Yield,
)

MCTS_TRACKING = LQNGParams(speed_margin=3.0, traffic_lane_tolerance=1.25, limit_brake_gain=10.0)
MCTS_TRAFFIC: tuple[TrafficRule, ...] = (
    LanesExactAlongside(distance=4.0),
    PassDetector(distance=10.0, clearance=1.5, speed_margin=0.3, on_prediction=True),
    LaneRuleGuard(margin=0.2),  # before the alongside discipline: a lane boundary is held first
    AlongsideDiscipline(clearance=1.5, reach=2.5, push=0.2),
    StationKeeping.gipps(
        distance=2.3, distance_curve=3.0, time=0.05, safe_braking=6.0, band=1.0, path_band=1.2, predict_time=0.4
    ),
    Yield(speed_margin=2.0, drop=0.6, reach=2.5, ahead=2.3, band=1.0, predict_time=0.4),
    SteerRateLimit(rate=5.0),
)

FIXED_LINE_TRACKING = LQNGParams(
    traffic_lane_tolerance=1.25, weights=LQNGWeights(heading=1.9, deny=0.1, avoid_scale=0.45)
)
# the fixed line held to mcts-lqng's rules of the road (the lanes its lane changes reach, room alongside, station
# keeping, a faster kart let in); the rules about driving a plan stay mcts-lqng's
FIXED_LINE_TRAFFIC: tuple[TrafficRule, ...] = tuple(
    rule for rule in MCTS_TRAFFIC if isinstance(rule, LaneRuleGuard | AlongsideDiscipline | StationKeeping | Yield)
)


def mcts_tracker(horizon: int) -> LQNGTracker:
    """``mcts-lqng``'s tracker, looking ``horizon`` steps ahead."""
    return LQNGTracker(replace(MCTS_TRACKING, horizon=horizon), MCTS_TRAFFIC)


def fixed_line_tracker(
    horizon: int, speed_scale: float = 1.0, traffic: tuple[TrafficRule, ...] = FIXED_LINE_TRAFFIC
) -> LQNGTracker:
    """``fixed-lqng``'s tracker, looking ``horizon`` steps ahead, at ``speed_scale`` of its speed targets, under
    ``traffic`` (by default mcts-lqng's rules of the road)."""
    return LQNGTracker(replace(FIXED_LINE_TRACKING, horizon=horizon, speed_scale=speed_scale), traffic)
