"""The static part of a race's 3D scene: the track's ground, road, walls, lanes, checkpoints and start line, the
geometry they are built from, and the colours of everything the scene draws.

Node names: ``/track/ground``, ``/track/surface`` (grey road mesh between the walls), ``/track/walls/left`` and
``/track/walls/right`` (thin vertical meshes), ``/track/lanes`` (the lane lines, one line-segments node),
``/track/start`` (the start/finish line), ``/track/checkpoints/cp{c}`` (purple boxes across the road).
"""

from __future__ import annotations

import math

import numpy as np
import viser

from sim_core.track import Track

WALL_HEIGHT = 0.6  # [m]

ROAD_COLOR = (105, 105, 112)
GROUND_COLOR = (196, 190, 170)
WALL_COLOR = (236, 236, 236)
LANE_COLOR = (250, 250, 250)
START_COLOR = (20, 20, 20)
CHECKPOINT_COLOR = (150, 40, 220)  # purple
WAYPOINT_COLOR = (20, 200, 60)  # green
PREDICTION_COLOR = (255, 140, 20)  # orange
SKY_LIGHT, GROUND_LIGHT = (255, 255, 255), (120, 112, 96)  # the hemisphere light's colours from above and below


def heading_wxyz(heading: float) -> tuple[float, float, float, float]:
    """Unit quaternion (w, x, y, z) of a rotation by ``heading`` [rad] about +z."""
    half = 0.5 * heading
    return (math.cos(half), 0.0, 0.0, math.sin(half))


def strip_mesh(a: np.ndarray, b: np.ndarray, za: float, zb: float) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and faces of a closed strip between the closed polylines ``a`` and ``b`` (both (M, 2))."""
    m = len(a)
    vertices = np.empty((2 * m, 3), dtype=np.float32)
    vertices[0::2, :2] = a
    vertices[0::2, 2] = za
    vertices[1::2, :2] = b
    vertices[1::2, 2] = zb
    i = np.arange(m)
    j = (i + 1) % m
    a0, b0, a1, b1 = 2 * i, 2 * i + 1, 2 * j, 2 * j + 1
    faces = np.concatenate([np.stack([a0, b0, a1], axis=1), np.stack([a1, b0, b1], axis=1)]).astype(np.uint32)
    return vertices, faces


def lane_polylines(track: Track) -> np.ndarray:
    """(n_lanes, M, 2) world positions of every lane along the whole centre line (lane 1 first)."""
    frac = np.asarray(track.lane_fractions, dtype=float)[:, None]
    offsets = np.where(frac > 0, frac * track.lane_half_left[None, :], frac * track.lane_half_right[None, :])
    return track.centre_xy[None, :, :] + track.centre_normal[None, :, :] * offsets[:, :, None]


def polyline_segments(points: np.ndarray, z: float, step: int = 1) -> np.ndarray:
    """(S, 2, 3) segments of a closed polyline, taking every ``step``-th point."""
    p = points[::step]
    seg = np.empty((len(p), 2, 3), dtype=np.float32)
    seg[:, 0, :2] = p
    seg[:, 1, :2] = np.roll(p, -1, axis=0)
    seg[:, :, 2] = z
    return seg


def add_lighting(server: viser.ViserServer) -> None:
    """Light the scene: viser's default lights and a hemisphere light for the soft ambient. Not an environment
    map: a browser without a GPU spends ~8 s filtering the map's image before it shows the scene at all (measured
    in chromium's software WebGL: the 3D view ready in 3-5 s instead of 11-12 s)."""
    server.scene.configure_environment_map(None)
    server.scene.add_light_hemisphere("/lights/sky", sky_color=SKY_LIGHT, ground_color=GROUND_LIGHT, intensity=1.2)


def add_track(server: viser.ViserServer, track: Track) -> None:
    """Add the track's nodes to ``server``'s scene and aim its initial camera at the whole track."""
    scene = server.scene
    lo = np.minimum(track.left_wall.min(axis=0), track.right_wall.min(axis=0))
    hi = np.maximum(track.left_wall.max(axis=0), track.right_wall.max(axis=0))
    centre = 0.5 * (lo + hi)
    extent = float(max(hi[0] - lo[0], hi[1] - lo[1], 20.0))
    server.initial_camera.look_at = (float(centre[0]), float(centre[1]), 0.0)
    server.initial_camera.position = (float(centre[0]), float(centre[1] - 0.6 * extent), 0.6 * extent)

    size = extent * 1.4
    scene.add_grid(
        "/track/ground",
        width=size,
        height=size,
        plane="xy",
        cell_size=5.0,
        section_size=25.0,
        position=(float(centre[0]), float(centre[1]), -0.05),
        plane_color=GROUND_COLOR,
        plane_opacity=1.0,
        cell_color=(180, 174, 154),
        section_color=(160, 154, 134),
        fade_distance=3.0 * extent,
        shadow_opacity=0.0,
    )
    vertices, faces = strip_mesh(track.left_wall, track.right_wall, 0.0, 0.0)
    scene.add_mesh_simple(
        "/track/surface",
        vertices,
        faces,
        color=ROAD_COLOR,
        side="double",
        flat_shading=True,
        cast_shadow=False,
        receive_shadow=0.3,
    )
    for side, wall in (("left", track.left_wall), ("right", track.right_wall)):
        vertices, faces = strip_mesh(wall, wall, 0.0, WALL_HEIGHT)
        scene.add_mesh_simple(
            f"/track/walls/{side}", vertices, faces, color=WALL_COLOR, side="double", cast_shadow=False
        )

    lanes = lane_polylines(track)
    segments = np.concatenate([polyline_segments(lane, 0.02, step=2) for lane in lanes])
    scene.add_line_segments("/track/lanes", segments, LANE_COLOR, thickness=0.12)

    width = float(track.lane_half_left[0] + track.lane_half_right[0])
    for c in range(track.n_checkpoints):
        point, normal = track.checkpoint_frame(c)
        left = float(track.width_left[track.checkpoint_sample[c]])
        right = float(track.width_right[track.checkpoint_sample[c]])
        mid = point + normal * 0.5 * (left - right)
        heading = math.atan2(-float(normal[0]), float(normal[1]))  # the tangent is the normal turned right
        scene.add_box(
            f"/track/checkpoints/cp{c}",
            color=CHECKPOINT_COLOR,
            dimensions=(0.6, left + right, 0.2),
            position=(float(mid[0]), float(mid[1]), 0.1),
            wxyz=heading_wxyz(heading),
            opacity=0.85,
            cast_shadow=False,
        )
    point, normal = track.checkpoint_frame(0)
    across = np.stack([point + normal * width * 0.55, point - normal * width * 0.55])
    scene.add_line_segments(
        "/track/start", np.array([[[*across[0], 0.14], [*across[1], 0.14]]]), START_COLOR, thickness=0.25
    )
