"""A race gives the same trajectory stepped alone or inside a batch of 1024, and twice with the same seed."""

from __future__ import annotations

import numpy as np
import pytest

from sim_core.track_io import get_track
from sim_core.world import World

N_STEPS = 300


def seeded_actions(seed: int, n_races: int, n_karts: int) -> np.ndarray:
    """(N_STEPS, B, K, 2) piecewise-constant driving inputs, different for every race."""
    rng = np.random.default_rng(seed)
    blocks = rng.uniform(-1, 1, (N_STEPS // 20 + 1, n_races, n_karts, 2))
    blocks[..., 1] = np.abs(blocks[..., 1])  # mostly forward
    return np.repeat(blocks, 20, axis=0)[:N_STEPS]


def spread_start(world: World, seed: int) -> None:
    rng = np.random.default_rng(seed + 1)
    for b in range(world.n_races):
        s = rng.uniform(0, world.track.length)
        world.place_kart(b, 0, s, 1.25, speed=8.0)
        world.place_kart(b, 1, s - 2.5, -1.25, speed=10.0)


def test_race_alone_equals_race_in_a_batch_of_1024() -> None:
    track = get_track("complex")
    batch = World(track, 1024, 2)
    spread_start(batch, 7)
    actions = seeded_actions(7, 1024, 2)
    chosen = [0, 17, 511, 1023]
    alone = {b: World(track, 1, 2) for b in chosen}
    for b, world in alone.items():
        for k in range(2):
            world.fstate[0, k] = batch.fstate[b, k]
            world.istate[0, k] = batch.istate[b, k]
        world.sense()
    for step in range(N_STEPS):
        batch.step(actions[step])
        for b, world in alone.items():
            world.step(actions[step, b : b + 1])
    for b, world in alone.items():
        for name, array in world.state_arrays().items():
            assert np.array_equal(array[0], batch.state_arrays()[name][b], equal_nan=True), (b, name)


def test_same_seed_same_race() -> None:
    track = get_track("oval")
    runs = []
    for _ in range(2):
        world = World(track, 8, 2)
        spread_start(world, 3)
        actions = seeded_actions(3, 8, 2)
        for step in range(N_STEPS):
            world.step(actions[step])
        runs.append(world.state_arrays())
    for name in runs[0]:
        assert np.array_equal(runs[0][name], runs[1][name], equal_nan=True), name
    # and it did something: the karts moved and crossed checkpoints
    assert runs[0]["istate"][:, :, 1].max() > 0


def test_a_restored_state_races_on_as_the_state_it_was_copied_from() -> None:
    """Branching a race: copy the state half way, race on, put the copy back and race on again with the same
    inputs: the same trajectory, every counter included; a copy of a world of another size is refused."""
    world = World(get_track("complex"), 2, 2)
    spread_start(world, 5)
    actions = seeded_actions(5, 2, 2)
    half = N_STEPS // 2
    for t in range(half):
        world.step(actions[t])
    saved = world.state_arrays()
    for t in range(half, N_STEPS):
        world.step(actions[t])
    first = world.state_arrays()
    world.restore_state(saved)
    for t in range(half, N_STEPS):
        world.step(actions[t])
    second = world.state_arrays()
    assert all(np.array_equal(first[name], second[name], equal_nan=True) for name in first)
    assert not np.array_equal(first["fstate"], saved["fstate"])
    other = World(get_track("complex"), 1, 2)
    with pytest.raises(ValueError, match="another world"):
        other.restore_state(saved)
