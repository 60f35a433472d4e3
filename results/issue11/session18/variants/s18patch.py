"""Session 18's scratch variants of mcts-lqng, applied on import from environment switches (none set: the tree as
committed). Not shipped; kept so that the README's variant figures rerun. Used together with session 17's switches
(``../../session17/variants/s17patch.py``: ``TRK``, ``GAME``, ...).

* ``IW=0.5``: ``high_level.INTERACTION_WINDOW`` (a waypoint is tactical when another kart is predicted this close);
* ``NOSQ=2.0``: the along-track distance within which ``MCTSPlanner._no_squeeze`` keeps the ego's lane next to a
  kart ahead (the game's collision distance, 3 m, as shipped);
* ``PSB=0``: ``planned_speeds_behind`` off (the line's speed profile binds behind another kart too);
* ``DIVE="16:4,17:4"``: from lap 2 on, with another kart less than ``DIVE_GAP`` m (default 15) ahead, the ego's
  waypoints at those checkpoints (modulo the lap) are sent to those lanes (forced dives to the inside);
* ``HMARGIN=0.15``: ``planner.HOLD_MARGIN``, what a new plan must gain over a kept pass to replace it (0.05 s);
* ``SLACK=1``: ``lane_change_slack`` of the planners built from the registry (mcts-lqng's is 0);
* ``HOLD=0.05``: ``hold_gain`` of every planner with a racing-line margin (what ``hold_gain_s`` now does);
  ``HOLD=none``: no pass commitment. ``HOLD=none TRK=pass_distance=0.0`` is session 17's mcts-lqng (commit
  24b40a4), on which the README's variant figures were measured.
"""

import os
import sys
from dataclasses import replace

from controllers.tactical import high_level
from controllers.tactical import planner as tactical_planner

if os.environ.get("IW"):
    high_level.INTERACTION_WINDOW = float(os.environ["IW"])
    print("IW", high_level.INTERACTION_WINDOW, file=sys.stderr)

if os.environ.get("NOSQ"):
    _nosq = float(os.environ["NOSQ"])
    _orig_no_squeeze = high_level.MCTSPlanner._no_squeeze

    def _no_squeeze(self, plan, me, karts):
        saved = self.params
        self.params = replace(saved, collision_distance=_nosq)
        try:
            return _orig_no_squeeze(self, plan, me, karts)
        finally:
            self.params = saved

    high_level.MCTSPlanner._no_squeeze = _no_squeeze
    print("NOSQ", _nosq, file=sys.stderr)

if os.environ.get("PSB") == "0":
    _orig_init = high_level.MCTSPlanner.__init__

    def _init(self, *args, **kwargs):
        kwargs["planned_speeds_behind"] = False
        _orig_init(self, *args, **kwargs)

    high_level.MCTSPlanner.__init__ = _init
    print("PSB off", file=sys.stderr)

if os.environ.get("DIVE"):
    _dive = {int(a): int(b) for a, b in (kv.split(":") for kv in os.environ["DIVE"].split(","))}
    _dive_gap = float(os.environ.get("DIVE_GAP", "15"))
    _orig_plan = high_level.MCTSPlanner.plan

    def _plan(self, observation):
        plan = _orig_plan(self, observation)
        track = self._context.track
        me = next(k for k in observation.karts if k.index == observation.ego)
        if me.checkpoints_passed < track.n_checkpoints:
            return plan
        ahead = [
            k for k in observation.karts if k.index != me.index and 0 < track.gap(me.progress, k.progress) < _dive_gap
        ]
        if not ahead:
            return plan
        waypoints = []
        for w in plan.ego_waypoints:
            lane = _dive.get(w.checkpoint % track.n_checkpoints)
            if lane is not None:
                p = track.lane_point(w.checkpoint, lane)
                w = replace(w, lane=lane, position=(float(p[0]), float(p[1])))
            waypoints.append(w)
        self._committed = {w.checkpoint: w.lane for w in waypoints}
        return replace(plan, waypoints={**plan.waypoints, plan.ego: tuple(waypoints)})

    high_level.MCTSPlanner.plan = _plan
    print("DIVE", _dive, _dive_gap, file=sys.stderr)

if os.environ.get("HOLD"):
    _hold = None if os.environ["HOLD"] == "none" else float(os.environ["HOLD"])
    _orig_tp = tactical_planner.TacticalPlanner.__init__

    def _tp(self, *args, **kwargs):
        _orig_tp(self, *args, **kwargs)
        if self.deviation_gain is not None:
            self.hold_gain = _hold

    tactical_planner.TacticalPlanner.__init__ = _tp
    print("HOLD", _hold, file=sys.stderr)

if os.environ.get("SLACK"):
    _slack = int(os.environ["SLACK"])
    _orig_from_settings = high_level.MCTSPlanner.from_settings.__func__

    def _from_settings(cls, settings, **kwargs):
        kwargs["lane_change_slack"] = _slack
        return _orig_from_settings(cls, settings, **kwargs)

    high_level.MCTSPlanner.from_settings = classmethod(_from_settings)
    print("SLACK", _slack, file=sys.stderr)

if os.environ.get("HMARGIN"):
    tactical_planner.HOLD_MARGIN = float(os.environ["HMARGIN"])
    print("HMARGIN", tactical_planner.HOLD_MARGIN, file=sys.stderr)
