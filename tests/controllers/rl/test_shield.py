"""The line-speed shield: its ceiling against the racing line's profile, when it brakes, and that it holds the
RL agents under the ceiling in a race where the policy alone does not stay there."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from controllers.base import Action
from controllers.race import RaceSpec, run_race
from controllers.racing_line import optimise_racing_line
from controllers.registry import make_controller
from controllers.rl.shield import LineSpeedShield
from sim_core.kart import throttle_for_acceleration
from sim_core.observation import observe
from sim_core.params import kart_preset
from sim_core.track_io import get_track

KART = kart_preset("paper")
LINE = optimise_racing_line(get_track("complex"), KART)
SHIELD = LineSpeedShield.of(LINE, KART, margin=1.0, braking_use=0.7)


def test_the_ceiling_is_the_profile_plus_margin_at_most_and_brakes_earlier() -> None:
    """Nowhere above the profile plus the margin; below it only ahead of a braking zone, and there no faster
    than braking at 0.7 of the limit down to the next sample's ceiling."""
    ceiling = SHIELD.ceiling_speed[:-1]
    assert np.all(ceiling <= LINE.speed + 1.0 + 1e-9)
    assert np.any(ceiling < LINE.speed + 1.0 - 0.5)  # the earlier braking zones bind somewhere on complex
    ds = np.diff(SHIELD.s)
    nxt = np.append(ceiling[1:], ceiling[0])
    assert np.all(ceiling**2 <= nxt**2 + 2.0 * 0.7 * KART.braking * ds + 1e-6)


def test_on_a_straight_at_top_speed_the_ceiling_is_not_binding() -> None:
    s = float(LINE.s[int(np.argmax(LINE.speed))])
    assert SHIELD.ceiling(s) == pytest.approx(float(LINE.speed.max()) + 1.0, abs=0.3)


@given(
    steer=st.floats(-1.0, 1.0),
    throttle=st.floats(-1.0, 1.0),
    speed=st.floats(0.0, 16.0),
    progress=st.floats(0.0, 2000.0),
)
def test_the_shield_only_ever_lowers_the_pedal(steer: float, throttle: float, speed: float, progress: float) -> None:
    """Steering is the policy's; under the ceiling the action is untouched; over it the pedal is the harder of
    the policy's and the shield's brake, which grows with the excess."""
    action = Action(steer, throttle)
    out = SHIELD.limit(action, speed, progress)
    assert out.steer == steer
    assert out.throttle <= throttle
    excess = speed - SHIELD.ceiling(progress)
    if excess <= 0.0:
        assert out == action
    else:
        brake = throttle_for_acceleration(KART.as_array(), speed, -SHIELD.gain * excess)
        assert out.throttle == pytest.approx(min(throttle, brake))


def test_far_over_the_ceiling_it_brakes_fully() -> None:
    s = float(LINE.s[int(np.argmin(LINE.speed))])  # the slowest hairpin apex
    out = SHIELD.limit(Action(0.0, 1.0), SHIELD.ceiling(s) + 3.0, s)
    assert out.throttle == -1.0


def _worst_excess(shielded: bool) -> float:
    """Largest speed over the shield's ceiling [m/s] of mcts-rl alone for 40 s of ``complex``."""
    worst = [-np.inf]

    def watch(world, drivers, step):  # type: ignore[no-untyped-def]
        me = observe(world, 0)[0].karts[0]
        worst[0] = max(worst[0], me.speed - SHIELD.ceiling(me.progress))

    driver = make_controller("mcts-rl", line_speed_shield=shielded)
    spec = RaceSpec(track="complex", controllers=("mcts-rl",), seed=0, start_lanes=(2,), time_limit=40.0)
    run_race(spec, on_step=watch, drivers=[driver])
    return worst[0]


def test_in_a_race_the_shield_holds_the_kart_near_its_ceiling_where_the_policy_alone_does_not() -> None:
    """The shipped mcts-rl policy enters complex's corners over the ceiling by metres per second; shielded it
    stays within the proportional brake's lag (0.7 x 6 m/s^2 / 10 per s, about 0.4 m/s) and one held decision,
    except on the inside of a hairpin, where the centre-line progress the ceiling is indexed by runs up to twice
    as fast as the kart and the ceiling falls faster than full braking can follow: up to about 1 m/s there (the
    shield then holds full brake)."""
    assert _worst_excess(shielded=False) > 3.0
    assert _worst_excess(shielded=True) < 1.5
