"""The kart obeys its limits on the path, checked from positions alone (finite differences, as an outside audit
would): random and adversarial inputs (bang-bang steering, full lock at top speed, pushes from behind, wall
scrapes) never bend the path harder than the lateral limit of the current tyre wear outside contacts, never
move a kart faster than its top speed, and a wall never spins a kart."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as hs

from controllers.lane_follower import LaneFollower
from sim_core import state as st
from sim_core.kart import kart_step, max_slip, throttle_for_acceleration
from sim_core.params import DT, ORIGINAL_KART, PAPER_KART, KartParams, SimParams
from sim_core.state import PAIR_CONTACT
from sim_core.track_io import get_track
from sim_core.world import World

WINDOW = 5  # 0.1 s: the audit's averaging window for the lateral acceleration
GUARD = 3  # steps around a contact that are not judged
TOLERANCE = 1.03  # the allowance for finite differences


def lateral_accelerations(xy: np.ndarray, window: int = WINDOW) -> np.ndarray:
    """|lateral acceleration| [m/s^2] of a path sampled every DT, from positions only: per step, the turn of the
    finite-difference velocity times the speed (``|v1 x v2| / (|v1 + v2| / 2) / dt``), averaged over ``window``
    steps. (Differencing the velocity across the whole window instead would charge a turn made while braking
    at the speed before the braking.)"""
    v = np.diff(xy, axis=0) / DT
    v1, v2 = v[:-1], v[1:]
    mean_speed = 0.5 * np.linalg.norm(v1 + v2, axis=1)
    cross = v1[:, 0] * v2[:, 1] - v1[:, 1] * v2[:, 0]
    per_step = np.where(mean_speed > 0.5, cross / np.maximum(mean_speed, 1e-9) / DT, 0.0)
    if len(per_step) < window:
        return np.zeros(0)
    return np.abs(np.convolve(per_step, np.ones(window) / window, "valid"))


def run(world: World, actions: np.ndarray) -> dict[str, np.ndarray]:
    """Step ``world`` (one race) through ``actions`` (T, K, 2); record positions, state speeds, headings,
    wear and contact flags per step (index 0 is the state before the first step)."""
    K = world.n_karts
    xy = [world.positions[0].copy()]
    speed = [world.speeds[0].copy()]
    heading = [world.headings[0].copy()]
    wear = [world.fstate[0, :, st.F_WEAR].copy()]
    contact = [np.zeros(K, dtype=bool)]
    for a in actions:
        world.step(a[None])
        xy.append(world.positions[0].copy())
        speed.append(world.speeds[0].copy())
        heading.append(world.headings[0].copy())
        wear.append(world.fstate[0, :, st.F_WEAR].copy())
        touching = world.istate[0, :, st.I_WALL_CONTACT].astype(bool)
        touching |= ((world.pair_flags[0] | world.pair_flags[0].T) & PAIR_CONTACT).any(axis=1)
        contact.append(touching)
    return {
        "xy": np.array(xy),
        "speed": np.array(speed),
        "heading": np.array(heading),
        "wear": np.array(wear),
        "contact": np.array(contact),
    }


def dilate(flags: np.ndarray, reach: int) -> np.ndarray:
    """``flags`` widened by ``reach`` entries on either side."""
    out = flags.copy()
    for shift in range(1, reach + 1):
        out[shift:] |= flags[:-shift]
        out[:-shift] |= flags[shift:]
    return out


def assert_within_limits(rec: dict[str, np.ndarray], kart: KartParams) -> None:
    """From positions: lateral acceleration within the current wear's limit outside contacts, speed within top."""
    xy, contact, wear = rec["xy"], rec["contact"], rec["wear"]
    for k in range(xy.shape[1]):
        lateral = lateral_accelerations(xy[:, k])
        near = dilate(contact[:, k], GUARD)
        for i, a in enumerate(lateral):
            if near[i : i + WINDOW + 2].any():
                continue
            limit = float(kart.lateral_limit(wear[i, k]))
            assert a <= limit * TOLERANCE, f"kart {k} step {i}: {a:.2f} m/s^2 > {limit:.2f}"
        path_speed = np.linalg.norm(np.diff(xy[:, k], axis=0), axis=1) / DT
        free = ~(near[1:] | near[:-1])
        assert (path_speed[free] <= kart.top_speed * (1 + 1e-9)).all(), path_speed[free].max()
    assert (rec["speed"] <= kart.top_speed + 1e-9).all()


def straight_start(world: World, k: int, speed: float, lane: int = 2, s: float = 5.0, heading: float = 0.0) -> None:
    d = float(world.track.lane_offsets(0)[lane - 1])
    world.place_kart(0, k, s, d, speed=speed, heading_offset=heading)


segments = hs.lists(hs.tuples(hs.floats(-1.0, 1.0), hs.floats(-1.0, 1.0), hs.integers(1, 40)), min_size=1, max_size=20)


@settings(max_examples=40, deadline=None)
@given(
    plan=segments,
    speed=hs.floats(0.0, 15.0),
    lane=hs.integers(1, 4),
    preset=hs.sampled_from([PAPER_KART, ORIGINAL_KART]),
)
def test_random_inputs_never_beat_the_lateral_limit(
    plan: list[tuple[float, float, int]], speed: float, lane: int, preset: KartParams
) -> None:
    world = World(get_track("oval"), 1, 1, SimParams(kart=preset), sensors=False)
    straight_start(world, 0, speed, lane)
    actions = np.array([[[steer, throttle]] for steer, throttle, n in plan for _ in range(n)])
    assert_within_limits(run(world, actions), preset)


@settings(max_examples=30, deadline=None)
@given(period=hs.integers(1, 25), wear=hs.floats(0.0, 0.95), preset=hs.sampled_from([PAPER_KART, ORIGINAL_KART]))
def test_bang_bang_full_lock_at_top_speed_never_beats_the_lateral_limit(
    period: int, wear: float, preset: KartParams
) -> None:
    world = World(get_track("train-oval-large"), 1, 1, SimParams(kart=preset), sensors=False)
    world.place_kart(0, 0, 5.0, 0.0, speed=preset.top_speed, wear=wear)
    steer = np.where((np.arange(300) // period) % 2 == 0, 1.0, -1.0)
    actions = np.stack([steer, np.ones(300)], axis=-1)[:, None, :]
    rec = run(world, actions)
    assert_within_limits(rec, preset)


def test_a_steer_step_at_top_speed_bends_the_path_gradually() -> None:
    """The audit's example: steer 0.135 -> 1.0 at speed. The path may not jump sideways in one step."""
    world = World(get_track("train-oval-large"), 1, 1, sensors=False)
    world.place_kart(0, 0, 5.0, 0.0, speed=14.0)
    actions = np.array([[[0.135, 1.0]]] * 10 + [[[1.0, 1.0]]] * 20)
    rec = run(world, actions)
    per_step = lateral_accelerations(rec["xy"][:, 0], window=1)
    limit = float(PAPER_KART.lateral_limit(rec["wear"][0, 0]))
    assert per_step.max() <= limit * TOLERANCE


@settings(max_examples=25, deadline=None)
@given(front_speed=hs.floats(0.0, 14.0), gap=hs.floats(0.0, 3.0), lateral=hs.floats(-0.6, 0.6))
def test_pushes_from_behind_never_take_a_kart_past_top_speed(front_speed: float, gap: float, lateral: float) -> None:
    world = World(get_track("oval"), 1, 2, sensors=False)
    world.place_kart(0, 0, 10.0, lateral, speed=15.0)
    world.place_kart(0, 1, 10.0 + 2.0 + gap, 0.0, speed=front_speed)
    actions = np.tile([0.0, 1.0], (150, 2, 1))
    rec = run(world, actions)
    assert_within_limits(rec, PAPER_KART)
    assert rec["contact"].any()  # they did touch


@settings(max_examples=30, deadline=None)
@given(angle=hs.floats(0.05, 1.2), speed=hs.floats(3.0, 15.0), steer=hs.floats(0.1, 1.0), side=hs.sampled_from([-1, 1]))
def test_wall_scrapes_turn_the_kart_at_a_bounded_rate(angle: float, speed: float, steer: float, side: int) -> None:
    world = World(get_track("oval"), 1, 1, sensors=False)
    world.place_kart(0, 0, 8.0, 3.0 * side, heading_offset=angle * side, speed=speed)
    actions = np.tile([steer * side, 1.0], (150, 1, 1))
    rec = run(world, actions)
    kart = PAPER_KART
    # the kart's own yaw rate is at most min(a_lat / v, 2 v sin(max slip) / wheelbase) <= sqrt(a_lat * ...)
    own = math.sqrt(float(kart.lateral_limit(0.0)) * 2.0 * math.sin(max_slip(kart.as_array())) / kart.wheelbase)
    bound = kart.wall_yaw_rate + own
    turn = np.abs(np.remainder(np.diff(rec["heading"][:, 0]) + np.pi, 2 * np.pi) - np.pi) / DT
    assert turn.max() <= bound * (1 + 1e-6)
    assert rec["contact"][:, 0].any()
    assert_within_limits(rec, kart)


@pytest.mark.parametrize("preset", [PAPER_KART, ORIGINAL_KART], ids=lambda p: p.name)
def test_throttle_inverse_realises_the_commanded_acceleration(preset: KartParams) -> None:
    p = preset.as_array()
    world = World(get_track("train-oval-large"), 1, 1, SimParams(kart=preset), sensors=False)
    for speed in (1.0, 5.0, 10.0, 14.0):
        for accel in (-5.0, -2.5, -1.0, 0.0, 0.5, 2.0):
            throttle = throttle_for_acceleration(p, speed, accel)
            assert throttle == pytest.approx(float(preset.throttle_for_acceleration(speed, accel)))
            if -1.0 < throttle < 1.0:
                world.place_kart(0, 0, 5.0, 0.0, speed=speed)
                world.step(np.array([[[0.0, throttle]]]))
                assert world.speeds[0, 0] == pytest.approx(speed + accel * DT, abs=1e-9)


@pytest.mark.parametrize("preset", [PAPER_KART, ORIGINAL_KART], ids=lambda p: p.name)
def test_a_speed_controller_through_the_inverse_holds_top_speed(preset: KartParams) -> None:
    """Drag included, commanding zero acceleration at top speed holds it (a proportional map cruised 1 m/s under)."""
    p = preset.as_array()
    x = y = heading = slip = acc_yaw = speed = 0.0
    for _ in range(600):
        throttle = throttle_for_acceleration(p, speed, 4.0 * (preset.top_speed - speed))
        x, y, heading, speed, slip, _, acc_yaw = kart_step(p, x, y, heading, speed, slip, acc_yaw, 0.0, throttle, DT)
    assert speed == pytest.approx(preset.top_speed)
    assert y == 0.0 and heading == 0.0


def test_the_lane_follower_reaches_top_speed_on_a_straight() -> None:
    track = get_track("train-oval-large")
    world = World(track, 1, 1, sensors=False)
    follower = LaneFollower(track, world.params.kart)
    best = 0.0
    for _ in range(600):
        actions = follower.act_on(world, 0.0)
        world.step(actions)
        best = max(best, float(world.speeds[0, 0]))
    assert best >= 14.7


def test_the_slip_never_leaves_the_full_lock_slip() -> None:
    """The step keeps |slip| within the full-lock slip without clipping it (random inputs, full-lock wall
    scrapes and pushes in 64 two-kart races)."""
    world = World(get_track("complex"), 64, 2, sensors=False)
    limit = max_slip(world.kart_vector)
    rng = np.random.default_rng(1)
    worst = 0.0
    for i in range(1500):
        actions = rng.uniform(-1.0, 1.0, (64, 2, 2)) if i % 7 else np.tile([1.0, 1.0], (64, 2, 1))
        world.step(actions)
        worst = max(worst, float(np.abs(world.fstate[:, :, st.F_SLIP]).max()))
    assert limit * 0.9 < worst <= limit * (1 + 1e-12)  # it does reach full lock
