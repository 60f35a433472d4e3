"""The original team (2v2) logs read and scored as the original's parser scores them.

The oracle is ``../shared/spec/teams.md`` §3 (the parser's printout, per agent and per pairing), hard-coded here
and only here: every figure of its per-agent table and every pairing's wins are reproduced exactly, and so are its
findings on the data (the copied file, the front row's head start)."""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import pytest

from arena.original_logs import LogFormatError
from arena.original_team_logs import grid_slots, read_original_team_logs, read_team_log, team_log_files

LOGS = Path(__file__).resolve().parents[3] / "shared" / "spec" / "original_logs_teams"
on_the_logs = pytest.mark.skipif(
    not LOGS.is_dir(), reason=f"the original's team logs are not at {LOGS} (third-party data, kept outside the repo)"
)

# teams.md §3, per agent type: (race wins, mean team points, collisions, ILC, safety per kart-race, DNF karts)
PARSER_TABLE = {
    "mcts-rl": {"oval": (134, 15.57, 1.247, 0.529, 1.776, 0), "complex": (120, 14.29, 1.279, 0.156, 1.435, 20)},
    "mcts-lqng": {"oval": (69, 12.49, 0.607, 2.201, 2.807, 1), "complex": (106, 13.29, 0.818, 0.203, 1.021, 25)},
    "fixed-rl": {"oval": (90, 13.71, 1.732, 0.755, 2.487, 1), "complex": (85, 13.32, 1.583, 0.203, 1.786, 24)},
    "fixed-lqng": {"oval": (49, 12.00, 0.628, 2.234, 2.862, 0), "complex": (83, 13.12, 0.549, 0.151, 0.701, 3)},
    "e2e": {"oval": (138, 14.89, 1.380, 0.419, 1.799, 3), "complex": (86, 11.51, 1.284, 0.266, 1.549, 64)},
}
PARSER_COMBINED = {  # race wins, mean team points, safety, DNF karts over both tracks (the copy included)
    "mcts-rl": (254, 14.93, 1.605, 20),
    "mcts-lqng": (175, 12.89, 1.914, 26),
    "fixed-rl": (175, 13.51, 2.137, 25),
    "fixed-lqng": (132, 12.56, 1.781, 3),
    "e2e": (224, 13.20, 1.674, 67),
}
# teams.md §3, per pairing: A-B race wins on the oval and the complex track (None: the copied file)
PAIRING_WINS = {
    ("mcts-rl", "e2e"): ((29, 19), None),
    ("mcts-rl", "fixed-rl"): ((31, 17), (33, 15)),
    ("mcts-rl", "mcts-lqng"): ((37, 11), (28, 20)),
    ("mcts-rl", "fixed-lqng"): ((37, 11), (30, 18)),
    ("mcts-lqng", "fixed-lqng"): ((32, 16), (27, 21)),
    ("mcts-lqng", "fixed-rl"): ((21, 27), (31, 17)),
    ("mcts-lqng", "e2e"): ((5, 43), (28, 20)),
    ("fixed-rl", "fixed-lqng"): ((35, 13), (28, 20)),
    ("fixed-rl", "e2e"): ((11, 37), (25, 23)),
    ("fixed-lqng", "e2e"): ((9, 39), (24, 24)),
}


def test_the_grid_gives_every_assignment_of_karts_to_slots_twice_in_48_races() -> None:
    assert grid_slots(0) == (0, 1, 2, 3)
    assert grid_slots(23) == (3, 2, 1, 0)
    assert grid_slots(1) == (0, 1, 3, 2) and grid_slots(24) == grid_slots(0)
    assert set(Counter(grid_slots(k) for k in range(48)).values()) == {2}


def test_a_malformed_log_is_refused_naming_its_line(tmp_path: Path) -> None:
    folder = tmp_path / "logs"
    folder.mkdir()
    lines = ["Experiment 0"]
    for kart in ("MCTS-RL(0)", "MCTS-RL(1)", "E2E(0)", "E2E(1)"):
        lines += [f"{kart} Total Time: 80.0", f"{kart} Laps Completed: 4/4", f"{kart} Collisions: 0"]
    (folder / "MCTS_RL_vs_E2E_OvalDuos.txt").write_text("\n".join(lines) + "\n")
    (log,) = team_log_files(folder)
    with pytest.raises(LogFormatError, match=r"MCTS_RL_vs_E2E_OvalDuos\.txt:1: missing or malformed field"):
        read_team_log(log)
    (folder / "MCTS_RL_vs_E2E_OvalDuos.txt").write_text("Experiment 0\nKart(0) Total Time: 80.0\n")
    with pytest.raises(LogFormatError, match=":2: not 'TYPE"):
        read_team_log(log)
    with pytest.raises(FileNotFoundError, match="no team race logs"):
        team_log_files(tmp_path)


@on_the_logs
def test_every_figure_of_the_parsers_per_agent_table_is_reproduced() -> None:
    from arena.original_team_logs import team_logs_report

    report = team_logs_report(read_original_team_logs(LOGS))
    parser = report["parser"]
    assert isinstance(parser, dict)
    for agent, tracks in PARSER_TABLE.items():
        for track, (wins, points, collisions, lane_changes, safety, unfinished) in tracks.items():
            f = parser[track][agent]
            assert (f["races"], f["wins"], f["unfinished_karts"]) == (192, wins, unfinished), (agent, track)
            assert round(f["mean_points"], 2) == points
            assert round(f["collisions_per_kart_race"], 3) == collisions
            assert round(f["illegal_lane_changes_per_kart_race"], 3) == lane_changes
            assert round(f["safety_per_kart_race"], 3) == safety
        wins, points, safety, unfinished = PARSER_COMBINED[agent]
        f = parser["combined"][agent]
        assert (f["races"], f["wins"], round(f["mean_points"], 2), f["unfinished_karts"]) == (
            384,
            wins,
            points,
            unfinished,
        )
        assert round(f["safety_per_kart_race"], 3) == safety


@on_the_logs
def test_every_pairings_wins_are_reproduced_and_the_copied_file_is_left_out() -> None:
    from arena.original_team_logs import team_logs_report

    logs = read_original_team_logs(LOGS)
    assert logs.copies == {"MCTS_RL_vs_E2E_ComplexDuos.txt": "MCTS_RL_vs_E2E_OvalDuos.txt"}
    assert len(logs.races) == 20 * 48 and len(logs.genuine) == 19 * 48
    collections = {log.path.name: log.run for log in logs.files}
    assert collections["MCTS_LQR_vs_Fixed_LQR_OvalDuos2.txt"] == 2 and collections["MCTS_RL_vs_E2E_OvalDuos.txt"] == 1
    found = {}
    for pairing in team_logs_report(logs)["matchups"]:  # type: ignore[attr-defined]
        a, b = pairing["figures"]
        found[(tuple(pairing["teams"]), pairing["track"])] = (a["wins"], b["wins"])
    for (a, b), (oval, complex_) in PAIRING_WINS.items():
        for track, wins in (("oval", oval), ("complex", complex_)):
            key = ((a, b), track) if ((a, b), track) in found else ((b, a), track)
            if wins is None:
                assert key not in found
                continue
            assert found[key] == (wins if key[0] == (a, b) else wins[::-1]), (a, b, track)
    genuine = team_logs_report(logs)["genuine"]
    assert isinstance(genuine, dict)
    mcts_rl, e2e = genuine["complex"]["mcts-rl"], genuine["complex"]["e2e"]
    assert (mcts_rl["races"], mcts_rl["wins"], round(mcts_rl["mean_points"], 2), mcts_rl["unfinished_karts"]) == (
        144,
        91,
        13.94,
        20,
    )
    assert (
        e2e["wins"],
        round(e2e["mean_points"], 2),
        round(e2e["safety_per_kart_race"], 3),
        e2e["unfinished_karts"],
    ) == (
        67,
        11.32,
        1.455,
        63,
    )


@on_the_logs
def test_the_defects_state_the_front_rows_head_start() -> None:
    defects = read_original_team_logs(LOGS).defects()
    assert defects[0] == "MCTS_RL_vs_E2E_ComplexDuos.txt is a byte copy of MCTS_RL_vs_E2E_OvalDuos.txt"
    assert "oval: the winner started on the front row" in defects[1] and "in 432 of 480 races" in defects[1]
    assert "won 141 of 160" in defects[1]
    assert "in 379 of 432 races" in defects[2] and "won 120 of 144" in defects[2]
    assert any(d.startswith("18 races are won by one team and scored higher for the other") for d in defects)
    assert any(d.startswith("7 unfinished karts were taken out") for d in defects)
