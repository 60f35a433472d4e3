"""Every benchmark in ``benchmarks/`` runs and ends with its JSON line: each is run at a tiny size (its own options
make it small; the figures then mean nothing) in a process of its own, as a person runs it from the repo root, and
the last line it prints must parse as a JSON object with the benchmark's keys. A benchmark added without a row here
fails the first test."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow  # a process per benchmark, two of them with a real server

ROOT = Path(__file__).resolve().parents[2]
BENCHMARKS = ROOT / "benchmarks"

# file -> (options for a tiny run, keys its JSON line must have)
TINY: dict[str, tuple[list[str], set[str]]] = {
    "conditions.py": (
        [
            "--agents",
            "fixed-lqng",
            "--pairs",
            "fixed-lqng/lane-follower",
            "--tracks",
            "oval",
            "--levels",
            "1",
            "--seeds",
            "1",
            "--races",
            "2",
            "--laps",
            "1",
        ],
        {"varied", "levels", "solo", "max_solo_ratio_error", "pairs"},
    ),
    "decision_time.py": (
        ["--steps", "3", "--tracks", "oval"],
        {"slowest_decision_ms", "median_decision_ms", "budget_ms", "within_budget"},
    ),
    "lqng.py": (["--repeats", "5"], {"solve_ms_2p", "solve_ms_4p"}),
    "mcts.py": (
        ["--iterations", "300", "--plan-iterations", "50", "--tracks", "oval", "--field", "5"],
        {"iterations_per_s", "plan_2000_ms", "iterations_per_s_per_track", "plan_2000_ms_per_track", "iterations"}
        | {"plan_2000_ms_field", "field_karts"},
    ),
    "mcts_strength.py": (["--games", "3", "--budgets", "20,50"], {"optimal_first_move_fraction_by_iterations"}),
    "opponent_models.py": (
        ["--tracks", "oval", "--laps", "1", "--time-limit", "4"],
        {"plan_ms_p50", "plan_ms_max", "plan_ms_p50_racing_line", "reset_s_simulated", "per_field"},
    ),
    "racing_line.py": (
        ["--repeats", "1", "--tracks", "oval"],
        {"max_seconds_per_track", "seconds_per_track", "lap_time_ratio_optimised_vs_handset"},
    ),
    "serve_loop.py": (
        ["--sessions", "1", "--window", "1", "--settle", "0.5", "--inputs", "10"],
        {"p50_jitter_ms_1_sessions", "p99_jitter_ms_1_sessions", "overruns_1_sessions", "drive_reflect_ticks"},
    ),
    "sim_step.py": (
        ["--single-steps", "200", "--batch", "8", "--batch-steps", "20"],
        {"single_race_steps_per_s", "batched_kart_steps_per_s", "batch_size"},
    ),
    "soak.py": (
        ["--duration", "3", "--settle", "2", "--sample", "1", "--races", "2", "--drivers", "1", "--viewers", "1"],
        {"ticks", "tick_jitter_p99_ms", "memory_growth_pct", "errors", "errors_total"},
    ),
    "tournament.py": (
        [
            "--agents",
            "fixed-lqng,lane-follower",
            "--tracks",
            "oval",
            "--workers",
            "1",
            "--time-limit",
            "4",
            "--fixed-races",
            "1",
        ],
        {
            "races",
            "realtime_factor",
            "full_grid_minutes",
            "full_grid_minutes_per_race_runner",
            "batched_speedup",
            "kart_steps_per_s_fixed_line",
            "worker_start_s",
            "outside_kernels_share",
        },
    ),
    "training.py": (
        ["--steps", "512", "--warm-steps", "256", "--races", "4", "--buffer", "256", "--batch", "64"],
        {"env_steps_per_s", "update_bound_env_steps_per_s", "steps", "learn_s"},
    ),
}


def test_every_benchmark_has_a_tiny_run() -> None:
    assert sorted(p.name for p in BENCHMARKS.glob("*.py")) == sorted(TINY)


@pytest.mark.parametrize("name", sorted(TINY))
def test_the_benchmark_prints_its_json_line(name: str) -> None:
    options, keys = TINY[name]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    run = subprocess.run(
        [sys.executable, str(BENCHMARKS / name), *options],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert run.returncode == 0, run.stderr[-3000:]
    last = run.stdout.strip().splitlines()[-1]
    summary = json.loads(last)
    assert isinstance(summary, dict) and keys <= summary.keys(), (keys - summary.keys(), last)
    if name == "soak.py":  # a short soak is still a soak: no HTTP error, abnormal close or race ended badly
        assert summary["errors_total"] == 0, summary["errors"]
