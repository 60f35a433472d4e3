"""Audit the kart model from poses alone: solo races of registered controllers, with top speed and path lateral
acceleration recomputed by finite differences of the karts' positions (no project kinematics involved).

    .venv/bin/python scripts/physics_audit.py --tracks oval,complex --karts fixed-lqng,mcts-lqng,lane-follower

Prints one line per race and a JSON object as the last line: per controller and track, the race time, lap
times, top speed [m/s] and the p99.9 of the path's lateral acceleration averaged over 0.1 s [g] outside wall
contacts.
"""

from __future__ import annotations

import json

import numpy as np
import typer

from controllers.base import RaceContext
from controllers.race import load_any_track
from controllers.registry import make_controller
from sim_core import state as st
from sim_core.observation import observe
from sim_core.params import DT, GRAVITY, SimParams, kart_preset
from sim_core.world import World

app = typer.Typer(add_completion=False)

AVERAGE_STEPS = 5  # 0.1 s window for the lateral acceleration
CONTACT_GUARD = 5  # steps excluded on either side of a wall contact


def path_lateral_acceleration(xy: np.ndarray, dt: float, window: int = AVERAGE_STEPS) -> np.ndarray:
    """Signed lateral acceleration [m/s^2] of a path sampled every ``dt`` (rows of ``xy``), averaged over
    ``window`` steps: the change of the finite-difference velocity over the window, projected on the normal
    of the mean velocity. Entry i covers velocities i .. i + window."""
    v = np.diff(xy, axis=0) / dt
    dv = (v[window:] - v[:-window]) / (window * dt)
    mean_v = 0.5 * (v[window:] + v[:-window])
    speed = np.linalg.norm(mean_v, axis=1)
    cross = mean_v[:, 0] * dv[:, 1] - mean_v[:, 1] * dv[:, 0]
    return np.where(speed > 1.0, cross / np.maximum(speed, 1e-9), 0.0)


def solo_race(track_name: str, controller: str, seed: int, kart: str) -> dict[str, object]:
    """One kart alone on ``track_name``; figures from its poses."""
    track = load_any_track(track_name)
    params = SimParams(kart=kart_preset(kart))
    world = World(track, 1, 1, params)
    world.reset(start_lanes=(2,))
    driver = make_controller(controller)
    driver.reset(RaceContext(track, params.kart, 0, 1, world.lane_change_limit, seed))
    hold = max(1, round(1.0 / (DT * driver.rate_hz)))
    actions = np.zeros((1, 1, 2))
    xy = [world.positions[0, 0].copy()]
    walls = [False]
    lap_marks: list[float] = []
    n = track.n_checkpoints
    step = 0
    while not world.done[0]:
        if step % hold == 0:
            action = driver.act(observe(world, 0)[0])
            actions[0, 0] = (action.steer, action.throttle)
        passed_before = int(world.istate[0, 0, st.I_CP_PASSED])
        world.step(actions)
        passed = int(world.istate[0, 0, st.I_CP_PASSED])
        if passed // n > passed_before // n and passed > 0:
            lap_marks.append(float(world.fstate[0, 0, st.F_CROSS_TIME]))
        xy.append(world.positions[0, 0].copy())
        walls.append(bool(world.istate[0, 0, st.I_WALL_CONTACT]))
        step += 1
    path = np.array(xy)
    speeds = np.linalg.norm(np.diff(path, axis=0), axis=1) / DT
    lateral = np.abs(path_lateral_acceleration(path, DT))
    contact = np.array(walls)
    near_wall = np.convolve(contact.astype(float), np.ones(2 * CONTACT_GUARD + AVERAGE_STEPS + 1), "same") > 0
    clean = lateral[~near_wall[: len(lateral)]]
    result = world.result(0)
    laps = [b - a for a, b in zip([0.0, *lap_marks[:-1]], lap_marks, strict=True)] if lap_marks else []
    return {
        "track": track_name,
        "controller": controller,
        "finished": result.karts[0].finished,
        "race_time": result.karts[0].finish_time,
        "laps": [round(x, 3) for x in laps],
        "best_lap": round(min(laps[1:] or laps), 3) if laps else None,
        "top_speed": round(float(speeds.max()), 3),
        "lat_p999_g": round(float(np.quantile(clean, 0.999)) / GRAVITY, 3) if len(clean) else None,
        "lat_max_g": round(float(clean.max()) / GRAVITY, 3) if len(clean) else None,
        "wall_steps": int(contact.sum()),
    }


@app.command()
def main(
    tracks: str = typer.Option("oval,complex", help="comma-separated track names"),
    karts: str = typer.Option("fixed-lqng,mcts-lqng,lane-follower", help="comma-separated controllers"),
    seed: int = typer.Option(0),
    kart: str = typer.Option("paper", help="kart preset"),
) -> None:
    """Solo race of each controller on each track; the JSON summary is the last line."""
    rows = []
    for track_name in tracks.split(","):
        for controller in karts.split(","):
            row = solo_race(track_name, controller, seed, kart)
            rows.append(row)
            print(row, flush=True)
    print(json.dumps(rows))


if __name__ == "__main__":
    app()
