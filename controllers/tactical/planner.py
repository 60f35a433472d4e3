"""The tactical planner: builds the discrete game's root from the karts' states, searches it with MCTS and
returns waypoints for the ego kart and the predicted best responses of the others (paper section 4.1)."""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from controllers.plan import Plan, Waypoint
from controllers.racing_line import RacingLine
from controllers.tactical import rules
from controllers.tactical.calibration import calibrate_tables
from controllers.tactical.game import TIME_UNITS_PER_S, WEAR_UNITS, GameParams, GameTables, build_tables
from controllers.tactical.mcts import SearchTree, fastest_outcome
from sim_core.params import KartParams
from sim_core.track import Track

DEFAULT_EXPLORATION = 0.2  # UCT constant (values in [0, 1], value_scale 1 s): best measured on exact small games
DEFAULT_GREEDY = 0.8  # probability that a rollout move is the fastest legal one
TREE_CAPACITY_PLANS = 8  # a reused tree grows for up to this many plans' budgets before it starts afresh
PLAN_MIN_VISITS = 30  # a plan follows the search tree only through choices visited at least this often
COMMIT_MARGIN = 0.02  # value (0.02 = 0.05 s at value_scale 1 s) a new lane must gain to replace a committed one
HOLD_MARGIN = 0.05  # [s] a new choice must gain this much over a kept deviation from the racing line to replace it

Move = tuple[int, int, np.ndarray]  # (row of the mover, action, the game state after the move)


@dataclass(frozen=True)
class PlayerState:
    """What the planner needs of one kart: its (last or predicted next) crossing of a checkpoint."""

    kart: int  # index of the kart in the race
    checkpoint: int  # absolute checkpoint index of that crossing (not wrapped)
    lane: int  # 1-based lane at that crossing
    speed: float  # [m/s] speed at that crossing
    time: float  # [s] race time of that crossing
    wear: float  # [-] tyre wear at that crossing
    lane_changes: int  # the referee's eq. (10) gen_lane_var counter
    model: int = rules.MODEL_FREE  # how the game plays it: searched, or an opponent model's lanes (rules.MODEL_*)
    script: tuple[int, ...] = ()  # with rules.MODEL_SCRIPT: its 0-based lane at each checkpoint of a lap (-1: none)
    pace: float = 1.0  # [-] its section times over the game's model of the kart (controllers.tactical.pace)
    team: int = 0  # its team number from 1 (0: no team): the game values its team's result (controllers.tactical.value)


class TacticalPlanner:
    """MCTS over the discrete racing game for one ego kart. Deterministic for a seed (iteration budget).

    The game state only changes when a kart crosses a checkpoint, so re-plans between crossings see the
    same root and continue growing the same tree (tree reuse); a new root starts a fresh tree.
    """

    def __init__(
        self,
        track: Track,
        kart: KartParams,
        params: GameParams | None = None,
        *,
        iterations: int = 2000,
        seed: int = 0,
        exploration: float = DEFAULT_EXPLORATION,
        greedy: float = DEFAULT_GREEDY,
        lane_limit: int | None = None,
        line: RacingLine | None = None,
        deviation_gain: float | None = None,
        hold_gain: float | None = None,
    ) -> None:
        if deviation_gain is not None and line is None:
            raise ValueError("deviation_gain needs the racing line")
        if hold_gain is not None and deviation_gain is None:
            raise ValueError("hold_gain needs deviation_gain")
        self.track = track
        # [s] the searched lanes replace the racing line's only when they gain this much over it (None: always)
        self.deviation_gain = deviation_gain
        # [s] a previous plan that left the line is kept while it still gains this much over the line, and no
        # less than the new choice less ``HOLD_MARGIN`` (None: every plan chosen afresh)
        self.hold_gain = hold_gain
        self.params = params or GameParams()
        self.tables: GameTables = build_tables(track, kart, self.params, lane_limit)
        if line is not None:
            self.tables = calibrate_tables(self.tables, track, line, kart)
        self.iterations = iterations
        self.seed = seed
        self.exploration = exploration
        self.greedy = greedy
        self._plans = 0
        self._tree: SearchTree | None = None
        self._tree_root: np.ndarray | None = None
        self._tree_scripts: np.ndarray | None = None
        self._lane_points: dict[tuple[int, int], tuple[float, float]] = {}

    def reset(self) -> None:
        """Forget the search tree and the plan counter (a new race). The tree's arrays are kept: the next
        search starts a fresh tree in them (allocating them takes longer than a young tree's search)."""
        self._plans = 0
        if self._tree is not None:
            self._tree.size = 0
        self._tree_root = None

    # ------------------------------------------------------------------ root
    def speed_bin(self, speed: float) -> int:
        """Velocity bin of a real speed (the original always used bin 0 here: a bug not copied)."""
        tb = self.tables
        return int(np.clip(np.searchsorted(tb.bin_low, speed, side="right") - 1, 0, len(tb.bin_low) - 1))

    def root_state(self, players: Sequence[PlayerState], ego: int) -> tuple[np.ndarray, list[int]]:
        """The game's root: players within the section window of the ego, all moved to the leader's checkpoint.

        A player behind the leading checkpoint is advanced to it in its own lane by the game's own fastest legal
        moves (:meth:`_advance`; the original set its time from an older crossing instead). Times are relative
        to the earliest player.
        """
        by_kart = {p.kart: p for p in players}
        if ego not in by_kart:
            raise ValueError(f"ego kart {ego} is not among the players")
        me = by_kart[ego]
        window = self.params.section_window
        chosen = [me] + [p for p in players if p.kart != ego and abs(p.checkpoint - me.checkpoint) < window]
        leader_cp = max(p.checkpoint for p in chosen)
        state = np.zeros((len(chosen), rules.N_FIELDS), dtype=np.int64)
        scripts = np.full_like(self.tables.scripted_lane, -1)
        times = []
        for row, p in enumerate(chosen):
            state[row, rules.CHECKPOINT] = p.checkpoint
            state[row, rules.LANE] = p.lane - 1
            state[row, rules.PREV_LANE] = p.lane - 1
            if p.kart != ego and p.model >= rules.MODEL_SCRIPT:
                slot = row - 1  # the ego is row 0 and never scripted
                scripts[slot] = p.script
                state[row, rules.MODELLED] = rules.MODEL_SCRIPT + slot
            elif p.kart != ego:
                state[row, rules.MODELLED] = p.model
            state[row, rules.BIN] = self.speed_bin(p.speed)
            state[row, rules.WEAR] = round(min(max(p.wear, 0.0), 1.0) * WEAR_UNITS)
            state[row, rules.LANE_COUNT] = p.lane_changes
            state[row, rules.PACE] = round(p.pace * rules.PACE_UNITS)
            state[row, rules.TEAM] = p.team
            times.append(p.time + self._advance(state[row], leader_cp, p.speed))
            self._slow_to_feasible(state[row])
        earliest = min(times)
        for row, t in enumerate(times):
            state[row, rules.TIME] = round((t - earliest) * TIME_UNITS_PER_S)
            state[row, rules.PREV_TIME] = state[row, rules.TIME]
        self.tables = self.tables._replace(scripted_lane=scripts)
        return state, [p.kart for p in chosen]

    def best_response_lanes(self, players: Sequence[PlayerState], ego: int, kart: int) -> dict[int, int]:
        """``kart``'s 1-based lane at each checkpoint of the game played on from the present with no search,
        ``kart`` playing freely (its fastest legal moves) and everyone else by their models (the ego too: the
        racing line); empty when ``kart`` is outside the ego's game. Sets the tables' scripts like
        :meth:`root_state` (call it before the plan's own root)."""
        freed = [replace(p, model=rules.MODEL_FREE, script=()) if p.kart == kart else p for p in players]
        root, karts = self.root_state(freed, ego)
        if kart not in karts:
            return {}
        row = karts.index(kart)
        bins = len(self.tables.bin_low)
        root_cp = int(root[0, rules.CHECKPOINT])
        moves, _ = self._playout(root, root_cp, root_cp, None)
        return {int(state[row, rules.CHECKPOINT]): action // bins + 1 for mover, action, state in moves if mover == row}

    def _advance(self, row: np.ndarray, checkpoint: int, speed: float) -> float:
        """Move one player's state ``row`` (in place) forward to ``checkpoint`` in its own lane by the game's
        fastest legal moves, and return the time [s] that takes.

        A kart a checkpoint behind the leader may be on its way into a hairpin: carried there at its present
        speed it would enter the game faster than the corner can be braked for, a dead end with no legal move
        (10 of mcts-lqng's 108 plans in a race on ``complex`` behind fixed-lqng had no searched ego move for this
        reason). Where the game has no legal move in the lane (already a dead end), the kart keeps
        its speed on the way."""
        n = self.track.n_checkpoints
        single = row[np.newaxis, :].copy()
        seconds = 0.0
        lane = int(row[rules.LANE])
        while int(single[0, rules.CHECKPOINT]) < checkpoint:
            grip_now, grip_next = rules.mover_grip(self.tables, single, 0)
            vbin, arrival, count = rules.fastest_in_lane(self.tables, single, 0, lane, grip_now, grip_next)
            if vbin < 0:
                c = int(single[0, rules.CHECKPOINT])
                seconds += self.tables.distance[c % n, lane, lane] / max(speed, 1.0)
                single[0, rules.CHECKPOINT] += 1
                continue
            seconds += (arrival - int(single[0, rules.TIME])) / TIME_UNITS_PER_S
            rules.apply_outcome(self.tables, single, 0, lane, vbin, arrival, count)
        row[:] = single[0]
        row[rules.PREV_LANE] = lane
        return seconds

    def _slow_to_feasible(self, row: np.ndarray) -> None:
        """Lower one player's speed bin (in place) to the fastest from which it has a legal move, ignoring the
        other players. A kart predicted to reach a hairpin's entry faster than the game's braking model can
        stop it for the corner is a dead end (no legal move, the search then plans nothing for it); the real
        kart brakes a little harder or later than the model's profile, so the nearest state the game can
        continue from stands for it."""
        single = row[np.newaxis, :].copy()
        lanes = self.tables.distance.shape[1]
        grip_now, grip_next = rules.mover_grip(self.tables, single, 0)  # the bin does not change the grip
        while int(single[0, rules.BIN]) > 0:
            if any(rules.fastest_in_lane(self.tables, single, 0, j, grip_now, grip_next)[0] >= 0 for j in range(lanes)):
                break
            single[0, rules.BIN] -= 1
        row[rules.BIN] = single[0, rules.BIN]

    # ------------------------------------------------------------------ search
    def plan(self, players: Sequence[PlayerState], ego: int, committed: dict[int, int] | None = None) -> Plan:
        """Search from the current states and return the ego plan and the predicted responses.

        ``committed`` maps checkpoints to the ego's lanes of the previous plan: the new plan keeps such a lane
        unless its own choice is better by ``COMMIT_MARGIN`` (no churn between near-equal choices)."""
        root, karts = self.root_state(players, ego)
        horizon = self.params.horizon
        tb = self.tables
        max_actions = len(tb.bin_low) * tb.distance.shape[1]
        reuse = (
            self._tree is not None
            and self._tree_root is not None
            and self._tree_scripts is not None
            and np.array_equal(self._tree_root, root)
            and np.array_equal(self._tree_scripts, self.tables.scripted_lane)
        )
        budget = self.iterations
        needed = (self._tree.size if reuse and self._tree is not None else 0) + budget + 1
        if reuse and self._tree is not None and self._tree.capacity < needed:
            reuse = False  # the reused tree is full: start afresh
            needed = budget + 1
        if self._tree is None or self._tree.state.shape[1] != len(root) or self._tree.capacity < needed:
            self._tree = SearchTree(TREE_CAPACITY_PLANS * budget + 1, len(root), max_actions)
        tree = self._tree
        seed = self.seed * 1_000_003 + self._plans
        self._plans += 1
        t0 = time.perf_counter()
        tree.run(tb, root, horizon, budget, seed, self.exploration, self.greedy, resume=reuse)
        seconds = time.perf_counter() - t0
        self._tree_root = root.copy()
        self._tree_scripts = self.tables.scripted_lane.copy()
        return self._extract(tree, karts, ego, int(root[0, rules.CHECKPOINT]), budget, seconds, committed or {})

    def _principal_variation(self, tree: SearchTree, committed: dict[int, int]) -> list[int]:
        """The most visited line through the tree, keeping the ego's committed lanes unless a choice beats
        them by ``COMMIT_MARGIN`` (both choices visited at least ``PLAN_MIN_VISITS`` times)."""
        bins = len(self.tables.bin_low)

        def keep_commitment(parent: int, kids: list[int], best: int) -> int:
            if int(tree.mover[parent]) != 0:
                return best
            want = committed.get(int(tree.state[best][0, rules.CHECKPOINT]))
            if want is None or int(tree.action[best]) // bins == want - 1:
                return best
            keep = [
                k for k in kids if int(tree.action[k]) // bins == want - 1 and int(tree.visits[k]) >= PLAN_MIN_VISITS
            ]
            if keep:
                alt = max(keep, key=tree.rank)
                if tree.rank(alt)[1] >= tree.rank(best)[1] - COMMIT_MARGIN:
                    return alt
            return best

        return tree.principal_variation(PLAN_MIN_VISITS, keep_commitment)

    def _extract(
        self,
        tree: SearchTree,
        karts: list[int],
        ego: int,
        root_cp: int,
        iterations: int,
        seconds: float,
        committed: dict[int, int],
    ) -> Plan:
        tb = self.tables
        bins = len(tb.bin_low)
        per_player: dict[int, list[Waypoint]] = {k: [] for k in karts}
        path = self._principal_variation(tree, committed)
        moves: list[Move] = [
            (int(tree.mover[tree.parent[node]]), int(tree.action[node]), tree.state[node]) for node in path[1:]
        ]
        # beyond the searched tree the plan continues with everyone's fastest legal moves
        tail, _ = self._playout(tree.state[path[-1]], int(tree.round[path[-1]]), root_cp, {})
        moves += tail
        if self.deviation_gain is not None:
            moves = self._line_unless_beaten(tree.state[0], root_cp, moves, committed)
        for mover, action, states in moves:
            lane, vbin = divmod(action, bins)
            state = states[mover]
            checkpoint = int(state[rules.CHECKPOINT])
            per_player[karts[mover]].append(
                Waypoint(
                    checkpoint=checkpoint,
                    lane=lane + 1,
                    position=self._lane_point(checkpoint, lane + 1),
                    speed=float(tb.bin_high[vbin]),
                    time=float(state[rules.TIME]) / TIME_UNITS_PER_S,
                )
            )
        padded = self._pad(per_player[ego], root_cp, int(tree.state[0][0, rules.LANE]) + 1)
        waypoints = {k: tuple(w) for k, w in per_player.items()}
        return Plan(ego, root_cp, waypoints, iterations, tree.size, seconds, padded)

    def _playout(
        self, start: np.ndarray, start_round: int, root_cp: int, ego_lanes: dict[int, int] | None
    ) -> tuple[list[Move], bool]:
        """(moves, complete) of the game played on from ``start`` (its round ``start_round``) to the horizon of
        the root at ``root_cp`` with no search: every other player its model's move
        (:func:`~controllers.tactical.mcts.fastest_outcome`; an unmodelled one its fastest legal move), the ego its
        fastest legal move into ``ego_lanes[checkpoint]`` (0-based lanes; elsewhere its fastest legal move
        anywhere), or with ``ego_lanes`` None the racing line's lane as a modelled player. A stuck opponent leaves
        the game; ``complete``: the ego reached the horizon (a lane given with no legal move there, or no move at
        all, stops the playout)."""
        tb = self.tables
        bins = len(tb.bin_low)
        lanes = tb.distance.shape[1]
        state = start.copy()
        state[0, rules.MODELLED] = int(ego_lanes is None)
        final = root_cp + self.params.horizon
        moves: list[Move] = []
        r = start_round
        while r < final:
            p = rules.next_player(state, r)
            if p == rules.NO_PLAYER:
                r += 1
                continue
            lane = None if p != 0 or ego_lanes is None else ego_lanes.get(int(state[0, rules.CHECKPOINT]) + 1)
            if lane is None:
                action, arrival, count = fastest_outcome(tb, state, p, lanes, bins)
            else:
                grip_now, grip_next = rules.mover_grip(tb, state, p)
                vbin, arrival, count = rules.fastest_in_lane(tb, state, p, lane, grip_now, grip_next)
                action = lane * bins + vbin if vbin >= 0 else -1
            if action < 0:
                if p == 0:
                    return moves, False
                state[p, rules.CHECKPOINT] = -1
                continue
            rules.apply_outcome(tb, state, p, action // bins, action % bins, arrival, count)
            after = state.copy()
            after[0, rules.MODELLED] = 0
            moves.append((p, int(action), after))
        return moves, True

    def _line_unless_beaten(
        self, root: np.ndarray, root_cp: int, searched: list[Move], committed: dict[int, int] | None = None
    ) -> list[Move]:
        """The ego on the racing line (the opponent model's own play for it) unless the searched lanes, played
        out the same way at each lane's fastest legal speed, gain ``deviation_gain`` on the others over it.

        The search's principal line is a visit count through a tree whose values differ by hundredths, and its
        speed bins are sampled: read as a forecast it had the ego slower than its own line on straights and a
        line follower a body length behind level with it, and the ego then gave up the racing line to
        "defend" (fixed-lqng went round the outside of complex-reversed's first hairpin). Both candidates are
        timed by the same deterministic playout, so the margin compares like with like."""
        assert self.deviation_gain is not None
        line, line_complete = self._playout(root, root_cp, root_cp, None)
        if not line_complete:
            return searched
        mine, complete = self._playout(root, root_cp, root_cp, self._ego_lanes(searched))
        best = line
        if complete and _advantage(mine) >= _advantage(line) + self.deviation_gain * TIME_UNITS_PER_S:
            best = mine
        if self.hold_gain is not None and committed:
            kept = self._kept_deviation(root, root_cp, line, committed)
            if kept is not None and _advantage(kept) >= max(
                _advantage(line) + self.hold_gain * TIME_UNITS_PER_S,
                _advantage(best) - HOLD_MARGIN * TIME_UNITS_PER_S,
            ):
                return kept
        return best

    def _kept_deviation(
        self, root: np.ndarray, root_cp: int, line: list[Move], committed: dict[int, int]
    ) -> list[Move] | None:
        """The previous plan's lanes (``committed``, 1-based) played out from ``root`` when they leave the racing
        line's lanes somewhere ahead (None otherwise, or when they cannot be driven to the horizon)."""
        line_lanes = self._ego_lanes(line)
        lanes = {c: lane - 1 for c, lane in committed.items() if c > root_cp}
        if not any(line_lanes.get(c, lane) != lane for c, lane in lanes.items()):
            return None
        kept, complete = self._playout(root, root_cp, root_cp, lanes)
        return kept if complete else None

    def _ego_lanes(self, moves: list[Move]) -> dict[int, int]:
        """The ego's (row 0) 0-based lane at each checkpoint it reaches in ``moves``."""
        bins = len(self.tables.bin_low)
        return {int(state[0, rules.CHECKPOINT]): action // bins for mover, action, state in moves if mover == 0}

    def _pad(self, waypoints: list[Waypoint], root_cp: int, root_lane: int) -> int:
        """Fill the ego's plan to the horizon (a stuck ego: hold the lane at the lowest speed bin); returns how many
        waypoints that added."""
        tb = self.tables
        searched = len(waypoints)
        while len(waypoints) < self.params.horizon:
            last = waypoints[-1] if waypoints else None
            checkpoint = last.checkpoint + 1 if last else root_cp + 1
            lane = last.lane if last else root_lane
            time_s = (last.time if last else 0.0) + 1.0
            waypoints.append(
                Waypoint(checkpoint, lane, self._lane_point(checkpoint, lane), float(tb.bin_high[0]), time_s)
            )
        return len(waypoints) - searched

    def _lane_point(self, checkpoint: int, lane: int) -> tuple[float, float]:
        """:meth:`~sim_core.track.Track.lane_point` of ``lane`` (1-based) at ``checkpoint`` (modulo a lap), kept
        once computed (the track's geometry query takes longer than the rest of a waypoint's extraction)."""
        key = (checkpoint % self.track.n_checkpoints, lane)
        point = self._lane_points.get(key)
        if point is None:
            xy = self.track.lane_point(checkpoint, lane)
            point = self._lane_points[key] = (float(xy[0]), float(xy[1]))
        return point


def _advantage(moves: list[Move]) -> float:
    """The ego's (row 0) time advantage [0.01 s] over the mean of the others at the end of a playout (eq. (1)
    gen_obj); alone, its own time's negative (the faster the better)."""
    if not moves:
        return float("-inf")
    final = moves[-1][2]
    if final.shape[0] == 1:
        return float(-final[0, rules.TIME])
    return float(final[1:, rules.TIME].mean() - final[0, rules.TIME])
