"""Monte Carlo tree search over the discrete racing game (compiled).

UCT selection (``Q/n + c sqrt(ln N / n)``, Q from the point of view of the player who chose the edge),
expansion of one node per iteration, a rollout policy biased toward fast legal moves, and backpropagation
of every player's terminal value. The budget is a count of iterations, so a search is deterministic for a
seed; the tree is kept in preallocated arrays.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from numba import njit

from controllers.tactical import rules
from controllers.tactical.game import GameTables
from controllers.tactical.value import terminal_values
from sim_core.kernel_arrays import NO_REFCOUNT

NO_NODE = -1
REJECTION_TRIES = 8  # random legal move in rollouts: draws before falling back to listing every legal move


@njit(**NO_REFCOUNT)
def _round_of(state: np.ndarray, start_round: int, final_round: int) -> int:
    """The checkpoint whose round is being played: the lowest checkpoint any player still stands on."""
    r = start_round
    while r < final_round and rules.next_player(state, r) == rules.NO_PLAYER:
        r += 1
    return r


@njit(**NO_REFCOUNT)
def fastest_outcome(tb: GameTables, state: np.ndarray, p: int, n_lanes: int, bins: int) -> tuple[int, int, int]:
    """(action, arrival, lane-change count) of the legal move with the earliest arrival (then the smaller lane
    change); action -1 if there is none. A modelled player keeps to its lane (:func:`rules.allowed_lane`)."""
    grip_now, grip_next = rules.mover_grip(tb, state, p)
    only = rules.model_lane(tb, state, p)
    if only >= 0:
        vbin, arrival, count = rules.fastest_in_lane(tb, state, p, only, grip_now, grip_next)
        if vbin >= 0:
            return only * bins + vbin, arrival, count
        # no legal move in the line's lane: it avoids like anyone (and that lane has nothing to offer)
    action, best_key, best_arrival, best_count = -1, 1 << 60, 0, 0
    for lane in range(n_lanes):
        if lane == only:
            continue
        vbin, arrival, count = rules.fastest_in_lane(tb, state, p, lane, grip_now, grip_next)
        if vbin >= 0:
            key = arrival * 8 + abs(lane - state[p, rules.LANE])
            if key < best_key:
                action, best_key, best_arrival, best_count = lane * bins + vbin, key, arrival, count
    return action, best_arrival, best_count


@njit(**NO_REFCOUNT)
def _stuck_values(state: np.ndarray, p: int, values: np.ndarray) -> None:
    """Values when player ``p`` has no legal move: it loses (0) and the others win (1), unless it is a modelled
    player. Then nobody gains (0.5 each): the model's line follower would brake or swerve rather than stop,
    and shutting it in must not look like a win (it made the search block and slow down)."""
    for q in range(state.shape[0]):
        values[q] = 0.5 if state[p, rules.MODELLED] != 0 else 1.0
    if state[p, rules.MODELLED] == 0:
        values[p] = 0.0


@njit(**NO_REFCOUNT)
def _rollout(
    tb: GameTables,
    state: np.ndarray,
    start_round: int,
    final_round: int,
    greedy: float,
    moves: np.ndarray,
    reference: np.ndarray,
    values: np.ndarray,
) -> None:
    """Play the game to the horizon from ``state`` (modified in place) and write every player's value.

    The mover takes its fastest legal move (earliest arrival, then the smaller lane change) with probability
    ``greedy``, otherwise a uniformly random legal one; a modelled player always takes its fastest move into
    its predicted lane. A player with no legal move ends the game (:func:`_stuck_values`).
    """
    bins = tb.bin_low.shape[0]
    n_lanes = tb.distance.shape[1]
    n_actions = n_lanes * bins
    r = _round_of(state, start_round, final_round)
    while r < final_round:
        p = rules.next_player(state, r)
        if p == rules.NO_PLAYER:
            r += 1
            continue
        action, arrival, count = -1, 0, 0
        # a modelled player follows its model: the fastest move into its predicted lane
        if state[p, rules.MODELLED] != 0 or np.random.random() < greedy:
            action, arrival, count = fastest_outcome(tb, state, p, n_lanes, bins)
        else:
            # rejection sampling is uniform over the legal moves and usually needs one or two draws
            for _ in range(REJECTION_TRIES):
                candidate = np.random.randint(0, n_actions)
                arrival, count, ok = rules.move_outcome(tb, state, p, candidate // bins, candidate % bins)
                if ok:
                    action = candidate
                    break
            if action < 0:
                n_legal = rules.legal_moves(tb, state, p, moves)
                if n_legal > 0:
                    action = moves[np.random.randint(0, n_legal)]
                    arrival, count, _ = rules.move_outcome(tb, state, p, action // bins, action % bins)
        if action < 0:
            _stuck_values(state, p, values)
            return
        # the outcome found while choosing is the move's: no second evaluation
        rules.apply_outcome(tb, state, p, action // bins, action % bins, arrival, count)
    terminal_values(tb, state, reference, values)


@njit(**NO_REFCOUNT)
def greedy_line(tb: GameTables, state: np.ndarray, round_cp: int, final_round: int, out: np.ndarray) -> int:
    """Continue ``state`` (in place) to the horizon with every player taking its fastest legal move.

    Writes the moves as rows [player, action] into ``out`` and returns how many were played. A stuck player
    other than the ego (row 0) leaves the game (a row [player, -1]); a stuck ego stops the line.
    """
    bins = tb.bin_low.shape[0]
    n_lanes = tb.distance.shape[1]
    count = 0
    r = _round_of(state, round_cp, final_round)
    while r < final_round:
        p = rules.next_player(state, r)
        if p == rules.NO_PLAYER:
            r += 1
            continue
        action, arrival, changes = fastest_outcome(tb, state, p, n_lanes, bins)
        if action < 0:
            if p == 0:
                return count  # the ego (row 0) is stuck
            state[p, rules.CHECKPOINT] = -1  # another stuck player leaves the game (row [p, -1]); the others go on
            out[count, 0] = p
            out[count, 1] = -1
            count += 1
            continue
        rules.apply_outcome(tb, state, p, action // bins, action % bins, arrival, changes)
        out[count, 0] = p
        out[count, 1] = action
        count += 1
    return count


@njit(cache=True)
def reference_times(tb: GameTables, root_state: np.ndarray, horizon: int) -> np.ndarray:
    """Every player's time at the horizon when all play the fastest legal move (the pace reference)."""
    state = root_state.copy()
    start = state[:, rules.CHECKPOINT].min()
    moves = np.empty(tb.distance.shape[1] * tb.bin_low.shape[0], dtype=np.int64)
    dummy = np.zeros(state.shape[0])
    values = np.empty(state.shape[0])
    _rollout(tb, state, start, start + horizon, 1.0, moves, dummy, values)
    reference = np.empty(state.shape[0])
    for p in range(state.shape[0]):
        # a stuck greedy player keeps its last time; the reference then only ranks the others
        reference[p] = state[p, rules.TIME]
    return reference


@njit(cache=True)
def _init_root(
    tb: GameTables,
    root_state: np.ndarray,
    start_round: int,
    final_round: int,
    tree_state: np.ndarray,
    tree_parent: np.ndarray,
    tree_action: np.ndarray,
    tree_mover: np.ndarray,
    tree_round: np.ndarray,
    tree_visits: np.ndarray,
    tree_value: np.ndarray,
    tree_first_child: np.ndarray,
    tree_next_sibling: np.ndarray,
    tree_untried: np.ndarray,
    tree_untried_count: np.ndarray,
) -> int:
    """Make node 0 the root of a fresh tree; returns the node count (1)."""
    tree_state[0] = root_state
    tree_parent[0] = NO_NODE
    tree_action[0] = -1
    tree_round[0] = _round_of(root_state, start_round, final_round)
    tree_visits[0] = 0
    tree_value[0] = 0.0
    tree_first_child[0] = NO_NODE
    tree_next_sibling[0] = NO_NODE
    tree_mover[0] = rules.next_player(root_state, tree_round[0]) if tree_round[0] < final_round else rules.NO_PLAYER
    tree_untried_count[0] = 0
    if tree_mover[0] != rules.NO_PLAYER:
        tree_untried_count[0] = rules.legal_moves(tb, tree_state[0], tree_mover[0], tree_untried[0])
    return 1


@njit(cache=True)
def search(
    tb: GameTables,
    root_state: np.ndarray,
    horizon: int,
    iterations: int,
    seed: int,
    exploration: float,
    greedy: float,
    tree_state: np.ndarray,
    tree_parent: np.ndarray,
    tree_action: np.ndarray,
    tree_mover: np.ndarray,
    tree_round: np.ndarray,
    tree_visits: np.ndarray,
    tree_value: np.ndarray,
    tree_first_child: np.ndarray,
    tree_next_sibling: np.ndarray,
    tree_untried: np.ndarray,
    tree_untried_count: np.ndarray,
    resume_nodes: int,
) -> int:
    """Run ``iterations`` MCTS iterations from ``root_state``; returns the number of tree nodes.

    Node 0 is the root. ``tree_value[n]`` sums the value, for the player who moved into node n, of every
    simulation through n. With ``resume_nodes`` > 0 the search continues the tree of that many nodes already
    grown from the same root. The ``tree_*`` arrays must hold ``resume_nodes + iterations + 1`` nodes.
    """
    np.random.seed(seed)
    players = root_state.shape[0]
    start_round = root_state[:, rules.CHECKPOINT].min()
    final_round = start_round + horizon
    moves = np.empty(tree_untried.shape[1], dtype=np.int64)
    values = np.empty(players)
    scratch = np.empty_like(root_state)
    reference = reference_times(tb, root_state, horizon)

    if resume_nodes > 0:
        n_nodes = resume_nodes
    else:
        n_nodes = _init_root(
            tb,
            root_state,
            start_round,
            final_round,
            tree_state,
            tree_parent,
            tree_action,
            tree_mover,
            tree_round,
            tree_visits,
            tree_value,
            tree_first_child,
            tree_next_sibling,
            tree_untried,
            tree_untried_count,
        )
    for _ in range(iterations):
        # ---- selection
        node = 0
        while (
            tree_mover[node] != rules.NO_PLAYER and tree_untried_count[node] == 0 and tree_first_child[node] != NO_NODE
        ):
            log_n = math.log(max(tree_visits[node], 1))
            best, best_score = NO_NODE, -1e300
            child = tree_first_child[node]
            while child != NO_NODE:
                visits = tree_visits[child]
                score = tree_value[child] / visits + exploration * math.sqrt(log_n / visits)
                if score > best_score:
                    best, best_score = child, score
                child = tree_next_sibling[child]
            node = best
        # ---- expansion
        if tree_mover[node] != rules.NO_PLAYER and tree_untried_count[node] > 0:
            k = np.random.randint(0, tree_untried_count[node])
            action = tree_untried[node, k]
            tree_untried_count[node] -= 1
            tree_untried[node, k] = tree_untried[node, tree_untried_count[node]]
            child = n_nodes
            n_nodes += 1
            tree_state[child] = tree_state[node]
            rules.apply_move(tb, tree_state[child], tree_mover[node], action)
            tree_parent[child] = node
            tree_action[child] = action
            tree_visits[child] = 0
            tree_value[child] = 0.0
            tree_first_child[child] = NO_NODE
            tree_next_sibling[child] = tree_first_child[node]
            tree_first_child[node] = child
            tree_round[child] = _round_of(tree_state[child], tree_round[node], final_round)
            if tree_round[child] < final_round:
                tree_mover[child] = rules.next_player(tree_state[child], tree_round[child])
                tree_untried_count[child] = rules.legal_moves(
                    tb, tree_state[child], tree_mover[child], tree_untried[child]
                )
            else:
                tree_mover[child] = rules.NO_PLAYER
                tree_untried_count[child] = 0
            node = child
        # ---- simulation
        if tree_mover[node] != rules.NO_PLAYER and tree_untried_count[node] == 0 and tree_first_child[node] == NO_NODE:
            # the player to move is stuck
            _stuck_values(tree_state[node], tree_mover[node], values)
        else:
            scratch[:, :] = tree_state[node]
            _rollout(tb, scratch, tree_round[node], final_round, greedy, moves, reference, values)
        # ---- backpropagation: each node is credited with the value of the player who moved into it
        while node != NO_NODE:
            tree_visits[node] += 1
            parent = tree_parent[node]
            if parent != NO_NODE:
                tree_value[node] += values[tree_mover[parent]]
            node = parent
    return n_nodes


class SearchTree:
    """Preallocated arrays of one search tree (capacity ``iterations + 1`` nodes).

    The arrays are not cleared: the search writes every field of a node when it creates it, and nothing at or
    past ``size`` (nor an ``untried`` entry past the node's count) is ever read. So a tree is cheap to allocate
    and can start afresh in the same arrays.
    """

    def __init__(self, capacity: int, players: int, max_actions: int) -> None:
        self.capacity = capacity
        self.state = np.empty((capacity, players, rules.N_FIELDS), dtype=np.int64)
        self.parent = np.empty(capacity, dtype=np.int64)
        self.action = np.empty(capacity, dtype=np.int64)
        self.mover = np.empty(capacity, dtype=np.int64)
        self.round = np.empty(capacity, dtype=np.int64)
        self.visits = np.empty(capacity, dtype=np.int64)
        self.value = np.empty(capacity, dtype=np.float64)
        self.first_child = np.empty(capacity, dtype=np.int64)
        self.next_sibling = np.empty(capacity, dtype=np.int64)
        self.untried = np.empty((capacity, max_actions), dtype=np.int64)
        self.untried_count = np.empty(capacity, dtype=np.int64)
        self.size = 0

    def run(
        self,
        tb: GameTables,
        root_state: np.ndarray,
        horizon: int,
        iterations: int,
        seed: int,
        exploration: float,
        greedy: float,
        resume: bool = False,
    ) -> int:
        """Search ``iterations`` times from ``root_state``; ``resume`` continues the tree already grown from it."""
        start = self.size if resume and self.size > 0 else 0
        if start + iterations + 1 > self.capacity:
            raise ValueError(f"tree holds {self.capacity} nodes, {start + iterations + 1} needed")
        arrays = (self.state, self.parent, self.action, self.mover, self.round, self.visits, self.value)
        links = (self.first_child, self.next_sibling, self.untried, self.untried_count)
        self.size = search(tb, root_state, horizon, iterations, seed, exploration, greedy, *arrays, *links, start)
        return self.size

    def children(self, node: int) -> list[int]:
        """Child node indices of ``node``."""
        out = []
        child = int(self.first_child[node])
        while child != NO_NODE:
            out.append(child)
            child = int(self.next_sibling[child])
        return out

    def principal_variation(
        self, min_visits: int = 1, override: Callable[[int, list[int], int], int] | None = None
    ) -> list[int]:
        """Nodes from the root following the most visited child (ties: higher mean value), as long as that
        child has at least ``min_visits`` visits (deeper choices rest on too few samples to trust).
        ``override(parent, children, best)`` may pick another child instead (a planner's commitment)."""
        path = [0]
        while True:
            kids = self.children(path[-1])
            if not kids:
                return path
            best = max(kids, key=self.rank)
            if len(path) > 1 and int(self.visits[best]) < min_visits:
                return path
            if override is not None:
                best = override(path[-1], kids, best)
            path.append(best)

    def rank(self, node: int) -> tuple[int, float]:
        """(visits, mean value) of ``node``: how a child is chosen."""
        visits = int(self.visits[node])
        return visits, float(self.value[node]) / max(visits, 1)
