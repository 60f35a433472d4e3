"""Session 17's scratch variants of mcts-lqng, applied on import from environment switches (none set: the tree
as committed). Not shipped; kept so that the README's variant figures rerun.

* ``VARIANT="mcts-lqng:deviation_gain_s=0.0,..."``: registry defaults of a controller overridden;
* ``TRK="follow_band=1.6,follow_time=0.25,..."``: fields of mcts-lqng's tracker preset (``MCTS_TRACKING``);
* ``FTRK=...``: the same for fixed-lqng's (``FIXED_LINE_TRACKING``);
* ``GAME="collision_distance=2.5"``: the tactical game's parameters for planners built from the registry;
* ``GIPPS="d_min,b_use,tau"``: station keeping as a safe-speed (Gipps) limit instead of a time gap;
* ``SLOWF=0.95``: fixed-lqng drives at this fraction of its speed targets (what ``speed_scale`` now does);
* ``CANDS="a_max:k1/k2/..."``: the racing line unless beaten also by "hold lane L from root + a for k checkpoints".
"""

import os
import sys
from dataclasses import replace
from functools import partial

from controllers import registry

for _item in filter(None, os.environ.get("VARIANT", "").split(";")):
    _name, _rest = _item.split(":")
    _values = {k: eval(v) for k, v in (kv.split("=") for kv in _rest.split(","))}
    _spec = registry.REGISTRY[_name]

    def _build(params, _b=_spec.build, _o=_values):
        return _b(replace(params, **_o))

    registry._BY_NAME[_name] = replace(_spec, build=_build, factory=partial(_build, _spec.params_type()))
    print("VARIANT", _name, _values, file=sys.stderr)


def _over(text):
    out = {}
    for kv in filter(None, text.split(",")):
        k, v = kv.split("=")
        out[k] = eval(v)
    return out


t = _over(os.environ.get("TRK", ""))
w = {k[2:]: v for k, v in t.items() if k.startswith("w_")}
t = {k: v for k, v in t.items() if not k.startswith("w_")}
if w:
    t["weights"] = replace(registry.MCTS_TRACKING.weights, **w)
if t:
    registry.MCTS_TRACKING = replace(registry.MCTS_TRACKING, **t)
    print("TRK", registry.MCTS_TRACKING, file=sys.stderr)
# GAME="collision_distance=2.5,..." overrides the game's defaults in high_level's MCTSPlanner.from_settings
_g = _over(os.environ.get("GAME", ""))
if _g:
    from controllers.tactical import high_level

    _GP = high_level.GameParams
    high_level.GameParams = lambda **kw: _GP(**{**_g, **kw})
    print("GAME", _g, file=sys.stderr)
# GIPPS="d_min,b_use,tau": station keeping as a safe-speed (Gipps) limit: the follower can stop behind the leader
# braking at b_use of the limit, reacting after tau, with d_min [m] centre to centre left
_gp = os.environ.get("GIPPS", "")
if _gp:
    import math

    from controllers.lq import tracker as _tr

    _dmin, _buse, _tau = (float(x) for x in _gp.split(","))

    def _station_limit(self, kart, others, aim_offset=0.0):
        p = self.params
        b = self._context.kart.braking * _buse
        limit = math.inf
        cos_h, sin_h = math.cos(kart.heading), math.sin(kart.heading)
        for other in others:
            dx, dy = other.x - kart.x, other.y - kart.y
            ahead = dx * cos_h + dy * sin_h
            aside = -dx * sin_h + dy * cos_h
            if ahead <= p.follow_min_ahead or abs(aside) >= p.follow_band:
                continue
            room = ahead - _dmin - _tau * kart.speed
            limit = min(
                limit,
                math.sqrt(max(other.speed**2 + 2.0 * b * room, 0.0)) if room > 0 else max(other.speed + room, 0.0),
            )
        return limit

    _tr.LQNGTracker._station_limit = _station_limit
    print("GIPPS", _dmin, _buse, _tau, file=sys.stderr)
_f = _over(os.environ.get("FTRK", ""))
if _f:
    registry.FIXED_LINE_TRACKING = replace(registry.FIXED_LINE_TRACKING, **_f)
    print("FTRK", registry.FIXED_LINE_TRACKING, file=sys.stderr)
# SLOWF=0.95: fixed-lqng's tracker (follow_gain 0) targets this fraction of its speed everywhere
_sf = float(os.environ.get("SLOWF", "0") or 0)
if _sf:
    from controllers.lq import tracker as _tr2

    _orig_st = _tr2.LQNGTracker._speed_target

    def _slow_target(self, kart, first, second, top, brake):
        v = _orig_st(self, kart, first, second, top, brake)
        return v * _sf if self.params.follow_gain == 0.0 and kart.index == self._me_index else v

    _orig_act = _tr2.LQNGTracker.act

    def _act(self, observation, plan):
        self._me_index = observation.me.index
        return _orig_act(self, observation, plan)

    _tr2.LQNGTracker._speed_target = _slow_target
    _tr2.LQNGTracker.act = _act
    print("SLOWF", _sf, file=sys.stderr)
# CANDS="a_max,k_list": the racing line unless beaten also by 'hold lane L from root+a for k checkpoints'
_c = os.environ.get("CANDS", "")
if _c:
    import time as _time

    from controllers.tactical import planner as _planner

    _amax = int(_c.split(":")[0])
    _ks = [int(x) for x in _c.split(":")[1].split("/")]
    STATS = {"n": 0, "t": 0.0, "chosen": 0}

    def _lub(self, root, root_cp, searched):
        t = _time.perf_counter()
        bins = len(self.tables.bin_low)
        line, line_complete = self._playout(root, root_cp, root_cp, None)
        if not line_complete:
            return searched
        base = _planner._advantage(line)
        lanes = {int(s[0, _planner.rules.CHECKPOINT]): a // bins for m, a, s in searched if m == 0}
        best, best_adv = line, base + self.deviation_gain * 100 - 1e-9
        mine, ok = self._playout(root, root_cp, root_cp, lanes)
        if ok and _planner._advantage(mine) >= best_adv:
            best, best_adv = mine, _planner._advantage(mine)
        if root.shape[0] > 1:
            for L in range(self.tables.distance.shape[1]):
                for a in range(1, _amax + 1):
                    for k in _ks:
                        if a + k - 1 > self.params.horizon:
                            continue
                        cand = {root_cp + a + i: L for i in range(k)}
                        m, ok2 = self._playout(root, root_cp, root_cp, cand)
                        if ok2 and _planner._advantage(m) > best_adv:
                            best, best_adv = m, _planner._advantage(m)
                            STATS["chosen"] += 1
        STATS["n"] += 1
        STATS["t"] += _time.perf_counter() - t
        return best

    _planner.TacticalPlanner._line_unless_beaten = _lub
    import atexit

    atexit.register(lambda: print("CANDS", STATS, "ms/plan", 1000 * STATS["t"] / max(STATS["n"], 1), file=sys.stderr))
