"""The shipped RL agents as controllers: registry, weights, the live observation, races, determinism, swerving."""

from __future__ import annotations

import json
import pickle
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from controllers.base import RaceContext
from controllers.race import RaceSpec, run_race
from controllers.registry import controller_factory, controller_spec
from controllers.rl.actions import world_actions
from controllers.rl.batch import RaceBatch
from controllers.rl.config import AGENT_KINDS, EnvConfig
from controllers.rl.observations import OWN_FEATURES, TrackTables, build_frame, place_phantoms
from controllers.rl.policy import MissingWeightsError, load_policy, weights_folder
from controllers.rl.tracker import RLTracker
from sim_core import state as st
from sim_core.observation import observe
from sim_core.params import SimParams
from sim_core.track_io import get_track
from sim_core.world import World

ROOT = Path(__file__).resolve().parents[3]


@pytest.mark.parametrize("agent", AGENT_KINDS)
def test_shipped_weights_and_manifest(agent: str) -> None:
    folder = weights_folder(agent)
    manifest = json.loads((folder / "manifest.json").read_text())
    assert manifest["agent"] == agent and manifest["steps"] >= 8_000_000  # the paper's 8M at least
    stages = manifest["stages"]
    assert stages and sum(stage["steps"] for stage in stages) == pytest.approx(manifest["steps"], abs=20_000)
    assert all(stage["command"].startswith("karting train") and stage["commit"] for stage in stages)
    assert (folder / "curves.png").exists()
    policy = load_policy(folder)
    assert policy.obs_size == 220  # 4 frames of a 2-kart race
    assert np.all(np.abs(policy.act(np.zeros(policy.obs_size))) <= 1.0)


@pytest.mark.parametrize("agent", AGENT_KINDS)
def test_factories_pickle_and_build(agent: str) -> None:
    spec = controller_spec(agent)
    factory = pickle.loads(pickle.dumps(controller_factory(agent, spec.validate({}))))
    driver = factory()
    assert driver.name == agent


def test_missing_weights_fail_at_reset_with_a_clear_error(tmp_path: Path) -> None:
    track = get_track("oval")
    tracker = RLTracker("e2e", str(tmp_path))  # an empty folder
    with pytest.raises(MissingWeightsError, match="karting train"):
        tracker.reset(RaceContext(track, SimParams().kart, 0, 2, 3, seed=0))


def test_the_live_observation_is_the_training_observation() -> None:
    """The tracker's frame from an Observation equals build_frame on the World itself (lanes now, the eq. (10)
    counter and the rays included); only the opponent's accelerator flag is inferred (from its speed)."""
    track = get_track("oval")
    world = World(track, 1, 2, SimParams())
    world.reset()
    tracker = RLTracker("e2e")
    tracker.reset(RaceContext(track, world.params.kart, 0, 2, world.lane_change_limit, seed=0))
    tables = TrackTables.of(track)
    n = track.n_checkpoints
    rng = np.random.default_rng(0)
    for step in range(150):
        obs = observe(world, 0)[0]
        live = tracker.frame(obs, None)
        acc = tracker.accelerating.copy()
        ref = build_frame(world, tables, np.zeros((1, 2, n), np.int64), np.full((1, 2, n), 15.0), acc, world.time / 30)
        ref_frame = ref[0, 0]
        skip = OWN_FEATURES + 1  # the opponent's accelerator flag
        np.testing.assert_allclose(np.delete(live, skip), np.delete(ref_frame, skip), atol=1e-9, err_msg=str(step))
        raw = np.array([[0.6 * np.sin(step / 15), 1.0], [rng.uniform(-0.3, 0.3), 1.0]])
        inputs, _ = world_actions(world.params.kart, world.fstate[0, :, st.F_SPEED], raw)
        world.step(inputs[None], n_steps=2)


def test_each_agent_races_headless_in_a_fresh_process() -> None:
    """The shipped weights load in a new interpreter, race on oval and complex, and torch is never imported."""
    script = """
import sys
from controllers.race import RaceSpec, run_race
for agent in ("mcts-rl", "fixed-rl", "e2e"):
    for track in ("oval", "complex"):
        out = run_race(RaceSpec(track=track, controllers=(agent, "lane-follower"), seed=1, time_limit=4.0))
        assert out.result.duration > 3.9, out.result
        print(agent, track, out.result.karts[0].checkpoints_passed)
assert "torch" not in sys.modules, "torch imported outside training"
"""
    done = subprocess.run(
        [sys.executable, "-c", script], cwd=ROOT, capture_output=True, text=True, timeout=600, check=False
    )
    assert done.returncode == 0, done.stderr[-3000:]
    assert len(done.stdout.splitlines()) == 6


def test_a_seeded_rl_race_is_deterministic() -> None:
    spec = RaceSpec(track="oval", controllers=("fixed-rl", "e2e"), seed=3, time_limit=6.0)
    first, second = run_race(spec, record=True), run_race(spec, record=True)
    assert first.result == second.result
    assert first.replay is not None and second.replay is not None
    assert first.replay.poses == second.replay.poses


def _track_heading(track, s: float) -> float:  # type: ignore[no-untyped-def]
    _, tangent = track.point_at(s)
    return float(np.arctan2(tangent[1], tangent[0]))


def test_swerving_on_a_straight_costs_the_swerve_penalty_per_referee_count() -> None:
    """A kart weaving lane to lane on the oval's main straight exceeds L = 3 lane changes: each illegal change
    the referee counts (I_ILLEGAL_STEP) costs exactly the swerve weight in that decision's reward terms."""
    config = EnvConfig(agent="e2e", tracks=("oval",))
    batch = RaceBatch(config, 1, seed=0)
    batch.reset()
    block = batch.blocks[0]
    w, track = block.world, block.world.track
    w.place_kart(0, 0, s=-18.0, d=-3.5, speed=8.0)  # the straight before the line, right-most lane
    w.place_kart(0, 1, s=120.0, d=0.0)  # the other kart out of the way
    w.sense(np.array([0]))
    block.illegal[:] = w.istate[:, :, st.I_ILLEGAL_STEP]
    block.passed[:] = w.istate[:, :, st.I_CP_PASSED]
    target, total = 3.5, 0
    for _ in range(100):
        f = w.fstate[0, 0]
        err = np.angle(np.exp(1j * (f[st.F_HEADING] - _track_heading(track, float(f[st.F_S])))))
        if abs(f[st.F_D] - target) < 0.5:
            target = -target
        steer = np.clip(np.clip(0.3 * (target - f[st.F_D]), -0.5, 0.5) - err, -1.0, 1.0)
        before = int(w.istate[0, 0, st.I_ILLEGAL_STEP])
        batch.step(np.array([[[steer, 1.0 if f[st.F_SPEED] < 8.0 else 0.0], [0.0, -1.0]]]))
        rise = int(w.istate[0, 0, st.I_ILLEGAL_STEP]) - before
        assert block.terms["swerve"][0, 0] == -config.weights.swerve * rise
        total += rise
    assert total >= 1
    assert track.straight_flags[int(w.istate[0, 0, st.I_CP_PASSED]) % track.n_checkpoints]


def test_a_solo_race_is_observed_as_a_solo_training_race() -> None:
    """Alone, the tracker shows the missing opponent as a finished phantom behind the ego; a training race with
    its opponent absent (``EnvConfig.solo_probability``) shows it the same way: the frames are equal."""
    track = get_track("oval")
    solo = World(track, 1, 1, SimParams())
    solo.reset(start_lanes=(2,))
    pair = World(track, 1, 2, SimParams())
    pair.reset(start_lanes=(2, 3))
    absent = np.array([[False, True]])
    place_phantoms(pair.fstate, pair.istate, absent)
    pair.sense(np.array([0]))  # as a training spawn does: the rays no longer see the absent kart
    tracker = RLTracker("e2e")
    tracker.reset(RaceContext(track, solo.params.kart, 0, 1, solo.lane_change_limit, seed=0))
    tables = TrackTables.of(track)
    n = track.n_checkpoints
    for step in range(150):
        live = tracker.frame(observe(solo, 0)[0], None)
        acc = tracker.accelerating.copy()
        ref = build_frame(pair, tables, np.zeros((1, 2, n), np.int64), np.full((1, 2, n), 15.0), acc, pair.time / 30)
        np.testing.assert_allclose(live, ref[0, 0], atol=1e-9, err_msg=str(step))
        raw = np.array([[0.6 * np.sin(step / 15), 1.0]])
        inputs, _ = world_actions(solo.params.kart, solo.fstate[0, :, st.F_SPEED], raw)
        solo.step(inputs[None], n_steps=2)
        pair.step(np.concatenate([inputs, np.zeros((1, 2))])[None], n_steps=2)
        place_phantoms(pair.fstate, pair.istate, absent)
