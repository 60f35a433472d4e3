"""Property tests that try to break the physics rules: karts driven anywhere stay on the track, never overlap,
and the follower is charged in a rear-end collision."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as hs

from sim_core import state as st
from sim_core.params import PAPER_KART
from sim_core.track_io import get_track
from sim_core.world import World

TRACKS = {name: get_track(name) for name in ("oval", "complex")}
HL, R = PAPER_KART.body_half_length, PAPER_KART.body_radius
WALL_TOLERANCE = 0.02  # [m]
OVERLAP_TOLERANCE = 0.03  # [m]


def body_points(world: World, k: int) -> np.ndarray:
    """Front end, centre and rear end of kart k's body axis in race 0."""
    f = world.fstate[0, k]
    direction = np.array([np.cos(f[st.F_HEADING]), np.sin(f[st.F_HEADING])])
    centre = np.array([f[st.F_X], f[st.F_Y]])
    return np.stack([centre + HL * direction, centre, centre - HL * direction])


def segment_distance(p0, p1, q0, q1, samples: int = 41) -> float:
    """Distance between two segments (dense sampling of one against the exact distance to the other)."""
    u = np.linspace(0.0, 1.0, samples)[:, None]
    pts = p0 + u * (p1 - p0)
    e = q1 - q0
    t = np.clip(((pts - q0) @ e) / (e @ e), 0.0, 1.0)
    closest = q0 + t[:, None] * e
    return float(np.min(np.linalg.norm(pts - closest, axis=1)))


def random_driving(seed: int, n_races: int, n_karts: int, n_steps: int, hold: int) -> np.ndarray:
    """Piecewise-constant random steer/throttle sequences, (n_steps, B, K, 2), throttle biased forward."""
    rng = np.random.default_rng(seed)
    n_blocks = n_steps // hold + 1
    steer = rng.uniform(-1, 1, (n_blocks, n_races, n_karts))
    throttle = rng.uniform(-0.6, 1.0, (n_blocks, n_races, n_karts))
    actions = np.stack([steer, throttle], axis=-1)
    return np.repeat(actions, hold, axis=0)[:n_steps]


@settings(max_examples=12)
@given(
    seed=hs.integers(0, 2**31 - 1),
    track_name=hs.sampled_from(sorted(TRACKS)),
    n_karts=hs.integers(1, 4),
    hold=hs.integers(5, 60),
    start_s=hs.floats(0.0, 1.0),
)
def test_karts_driven_anywhere_stay_on_track_and_never_overlap(
    seed: int, track_name: str, n_karts: int, hold: int, start_s: float
) -> None:
    track = TRACKS[track_name]
    world = World(track, 1, n_karts, sensors=False)
    base = start_s * track.length
    for k in range(n_karts):
        world.place_kart(0, k, base + 3.0 * (k // 2), (-1.5 if k % 2 else 1.5), speed=10.0)
    actions = random_driving(seed, 1, n_karts, 400, hold)
    for step in range(len(actions)):
        world.step(actions[step])
        if step % 4:
            continue
        for k in range(n_karts):
            for point in body_points(world, k):
                s, d = track.project(point)
                left, right = track.half_widths_at(s)
                assert d + R <= left + WALL_TOLERANCE, f"kart {k} through the left wall at step {step}"
                assert d - R >= -right - WALL_TOLERANCE, f"kart {k} through the right wall at step {step}"
        for i in range(n_karts):
            pi = body_points(world, i)
            for j in range(i + 1, n_karts):
                pj = body_points(world, j)
                gap = segment_distance(pi[0], pi[2], pj[0], pj[2]) - 2 * R
                assert gap >= -OVERLAP_TOLERANCE, f"karts {i} and {j} overlap by {-gap:.3f} m at step {step}"


@settings(max_examples=15)
@given(
    follower_speed=hs.floats(6.0, 15.0),
    leader_speed=hs.floats(0.0, 4.0),
    lateral_offset=hs.floats(-0.4, 0.4),
    gap=hs.floats(0.5, 6.0),
)
def test_rear_end_collision_is_charged_to_the_follower(
    follower_speed: float, leader_speed: float, lateral_offset: float, gap: float
) -> None:
    track = TRACKS["oval"]
    world = World(track, 1, 2, sensors=False)
    # the oval's long straight starts at checkpoint 22 (s ~ 226 m); both karts in lane 2 going straight
    leader_s = track.checkpoint_s[23] + 2.0 * (HL + R) + gap
    world.place_kart(0, 0, leader_s, 1.25, speed=leader_speed)
    world.place_kart(0, 1, track.checkpoint_s[23], 1.25 + lateral_offset, speed=follower_speed)
    actions = np.zeros((1, 2, 2))
    actions[0, 0, 1] = 0.0  # leader coasts
    actions[0, 1, 1] = 1.0  # follower keeps its foot down
    for _ in range(150):
        world.step(actions)
    assert world.istate[0, 1, st.I_CONTACTS] >= 1, "the karts must have touched"
    assert world.istate[0, 1, st.I_FAULTS] >= 1
    assert world.istate[0, 0, st.I_FAULTS] == 0


def test_a_long_contact_is_one_collision() -> None:
    track = TRACKS["oval"]
    world = World(track, 1, 2, sensors=False)
    world.place_kart(0, 0, track.checkpoint_s[23] + 3.0, 1.25, speed=2.0)
    world.place_kart(0, 1, track.checkpoint_s[23], 1.25, speed=6.0)
    actions = np.zeros((1, 2, 2))
    actions[0, 0, 1] = -1.0  # leader brakes to a stop
    actions[0, 1, 1] = 0.3  # follower keeps pushing for a second
    for _ in range(60):
        world.step(actions)
    assert world.istate[0, 1, st.I_FAULTS] == 1
