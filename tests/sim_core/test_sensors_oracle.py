"""Oracle for the fast range rays: the world's sensors equal brute force.

A kart on the track casts each ray against its grid cell's short list of wall segments for the ray's
direction bin (``cast_rays``, lists built offline by ``ray_grid``); :func:`sim_core.sensors.ray_walls`
tests the cell's whole reach list, which holds every wall segment within the rays' range. The lists are only
an acceleration: for any pose on any track the two must give the same distance. Hypothesis draws poses
(progress, lateral offset within the walls, any heading) on every built-in track and its reverse, with one
kart so that every ray ends on a wall or at its range.
"""

from __future__ import annotations

import math
from functools import cache

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sim_core.sensors import ray_walls
from sim_core.state import HIT_NONE, HIT_WALL
from sim_core.track_io import builtin_track_names, get_track
from sim_core.world import World

TRACKS = [name for base in builtin_track_names() for name in (base, f"{base}-reversed")]
INSIDE = 0.97  # poses up to this fraction of the local wall distance from the centre line
TOLERANCE = 1e-9  # [m] the two paths run the same segment test on the same floats


@cache
def world_on(name: str) -> World:
    """A one-kart world on ``name`` (built once per track: the ray grid is the expensive part)."""
    return World(get_track(name), n_races=1, n_karts=1)


def brute_force_rays(world: World) -> np.ndarray:
    """Distances of kart 0's rays by :func:`ray_walls` from the same origin and directions as the sensors."""
    sensors = world.params.sensors
    (x, y), heading = world.positions[0, 0], float(world.headings[0, 0])
    ch, sh = math.cos(heading), math.sin(heading)
    ox, oy = x + sensors.origin_forward * ch, y + sensors.origin_forward * sh
    distances = []
    for angle in world.ray_angles:
        ca, sa = math.cos(angle), math.sin(angle)
        dx, dy = ch * ca - sh * sa, sh * ca + ch * sa  # the heading rotated by the ray's angle, as the kernel
        distances.append(ray_walls(world.arrays, ox, oy, dx, dy, sensors.max_range))
    return np.array(distances)


def place(world: World, progress: float, lateral: float, heading_offset: float) -> tuple[float, float]:
    """Put kart 0 at ``progress`` (fraction of the lap) and ``lateral`` (fraction of the wall distance on that
    side), turned by ``heading_offset`` from the track direction, and cast its rays. Returns (s, d)."""
    track = world.track
    s = progress * track.length
    i = int(np.searchsorted(track.centre_s, s, side="right")) - 1
    d = lateral * (track.width_left[i] if lateral >= 0 else track.width_right[i]) * INSIDE
    world.place_kart(0, 0, s, d, heading_offset=heading_offset)
    world.sense()  # the sensors of a placed kart (reset() and step() call the same)
    return s, d


@pytest.mark.parametrize("name", TRACKS)
@settings(max_examples=300, deadline=None)
@given(
    progress=st.floats(0.0, 1.0, exclude_max=True),
    lateral=st.floats(-1.0, 1.0),
    heading_offset=st.floats(-math.pi, math.pi),
)
def test_grid_rays_equal_brute_force_rays_on_the_track(
    name: str, progress: float, lateral: float, heading_offset: float
) -> None:
    world = world_on(name)
    s, d = place(world, progress, lateral, heading_offset)
    fast = world.ray_dist[0, 0]
    slow = brute_force_rays(world)
    assert np.all(np.abs(fast - slow) <= TOLERANCE), (
        f"{name} at s={s:.3f} m, d={d:.3f} m, heading offset {heading_offset:.4f} rad: "
        f"grid {fast.tolist()} vs brute force {slow.tolist()}"
    )
    max_range = world.params.sensors.max_range
    assert np.array_equal(world.ray_hit[0, 0], np.where(slow < max_range, HIT_WALL, HIT_NONE))


@pytest.mark.parametrize("name", TRACKS)
def test_a_kart_on_the_centre_line_sees_the_walls_at_its_sides(name: str) -> None:
    # a check of the oracle itself: straight across the road the nearest wall is within the track's width
    world = world_on(name)
    place(world, 0.0, 0.0, 0.0)
    side = [i for i, a in enumerate(world.ray_angles) if abs(abs(a) - math.pi / 2) < 1e-9]
    assert side, "no ray at +-90 degrees"
    slow = brute_force_rays(world)
    track = world.track
    for i in side:
        assert 0.0 < slow[i] <= max(track.width_left.max(), track.width_right.max()) + 1.0
