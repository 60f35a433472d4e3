"""What a stored race or tournament measured: its manifest.

A :class:`Manifest` names the source (the git commit, and whether tracked files differed from it), every agent
with every public parameter's value (defaults included: ``controller_spec(name).validate(overrides)``) and the
SHA-256 of the trained weights it loads, the kart preset with its values, the race conditions (tracks, laps,
start lanes, start spread, plan latency, seeds, time limit) and the machine. It is stored with the record (a
race's result JSON, a tournament's row, ``karting race --json``, a published ``manifest.json``), so a table
read later says which agents it describes; :func:`stale_agents` says how the registry's agents differ from a
manifest's now.

Plain data out (:meth:`Manifest.to_json`), typed data in (:meth:`Manifest.from_json`); records stored before
manifests existed have none (``None``).
"""

from __future__ import annotations

import hashlib
import json
import os
import platform
import subprocess
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any

from controllers.parameters import Value
from controllers.race import RaceSpec, load_any_track
from controllers.registry import AGENT_SEPARATOR, ControllerSpec, controller_spec, parse_agent
from controllers.rl.policy import POLICY_FILE, weights_folder
from sim_core.params import RuleParams, kart_preset
from sim_core.world import grid_lanes

MANIFEST_VERSION = 1
UNKNOWN = "unknown"  # the commit outside a git checkout
COMMIT_VARIABLE = "KARTING_COMMIT"  # names the commit where the code is not a git checkout (an image, a copy)
HUMAN = "human"  # a kart driven over the server's drive websocket: no registered controller
ROOT = Path(__file__).resolve().parents[1]  # the checkout this code runs from (when it is one)

SpecLookup = Callable[[str], ControllerSpec[Any]]


@dataclass(frozen=True)
class AgentManifest:
    """One agent as it raced: the agent string as given, its controller, every public parameter's value and the
    trained weights it loads (``None``: it loads none)."""

    agent: str  # as given: NAME or NAME:KEY=VALUE:...
    name: str  # the registered controller
    parameters: Mapping[str, Value]  # every public parameter, defaults included, in declaration order
    weights: Mapping[str, str] | None = None  # {"path": relative to the checkout, "sha256": ...}

    @property
    def full(self) -> str:
        """The agent string with every parameter (``NAME:KEY=VALUE:...``): it builds the same driver."""
        return format_agent(self.name, self.parameters)

    def to_json(self) -> dict[str, Any]:
        """``{agent, name, full, parameters, weights}``."""
        weights = dict(self.weights) if self.weights is not None else None
        return {
            "agent": self.agent,
            "name": self.name,
            "full": self.full,
            "parameters": dict(self.parameters),
            "weights": weights,
        }

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> AgentManifest:
        """Read back :meth:`to_json` (``full`` is derived, not read)."""
        weights = data.get("weights")
        return cls(str(data["agent"]), str(data["name"]), dict(data["parameters"]), dict(weights) if weights else None)


@dataclass(frozen=True)
class Manifest:
    """A race's or a tournament's manifest (see the module docstring). ``conditions`` is plain JSON."""

    kind: str  # "race" or "tournament"
    commit: str  # git commit of the code, or "unknown"
    dirty: bool | None  # tracked files differed from the commit (None: unknown)
    agents: tuple[AgentManifest, ...]
    kart_preset: str
    kart: Mapping[str, Any]  # the preset's values (sim_core.params.KartParams)
    conditions: Mapping[str, Any]
    machine: Mapping[str, Any] = field(default_factory=dict)
    version: int = MANIFEST_VERSION

    def to_json(self) -> dict[str, Any]:
        """The JSON form stored with records."""
        return {
            "version": self.version,
            "kind": self.kind,
            "commit": self.commit,
            "dirty": self.dirty,
            "agents": [agent.to_json() for agent in self.agents],
            "kart_preset": self.kart_preset,
            "kart": dict(self.kart),
            "conditions": dict(self.conditions),
            "machine": dict(self.machine),
        }

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> Manifest:
        """Read back :meth:`to_json`."""
        return cls(
            str(data["kind"]),
            str(data["commit"]),
            data.get("dirty"),
            tuple(AgentManifest.from_json(a) for a in data["agents"]),
            str(data["kart_preset"]),
            dict(data.get("kart") or {}),
            dict(data.get("conditions") or {}),
            dict(data.get("machine") or {}),
            int(data.get("version", MANIFEST_VERSION)),
        )


def format_agent(name: str, parameters: Mapping[str, Value]) -> str:
    """``NAME:KEY=VALUE:...``, each value written so that :func:`controllers.registry.parse_agent` reads it back
    (JSON for numbers and booleans, and for text that would otherwise read as JSON)."""
    return AGENT_SEPARATOR.join([name, *(f"{key}={_agent_text(value)}" for key, value in parameters.items())])


def _agent_text(value: Value) -> str:
    if not isinstance(value, str):
        return json.dumps(value)
    try:
        json.loads(value)
    except json.JSONDecodeError:
        return value
    return json.dumps(value)  # "3" as text: quoted, or it would read back as the number


def describe_controller(
    name: str, overrides: Mapping[str, object], agent: str | None = None, lookup: SpecLookup = controller_spec
) -> AgentManifest:
    """The manifest entry of controller ``name`` with ``overrides``: every public parameter's value as the
    registry resolves it now (``KeyError``: unknown controller, ``ParameterError``: a bad parameter)."""
    if name == HUMAN:
        return AgentManifest(agent or HUMAN, HUMAN, {})
    params = lookup(name).validate(overrides)
    values: dict[str, Value] = asdict(params) if params is not None else {}
    return AgentManifest(agent or format_agent(name, overrides), name, values, _weights(name))  # type: ignore[arg-type]


def describe_agent(agent: str, lookup: SpecLookup = controller_spec) -> AgentManifest:
    """The manifest entry of an agent string (:func:`controllers.registry.parse_agent`)."""
    name, overrides = parse_agent(agent)
    return describe_controller(name, overrides, agent, lookup)


def _weights(name: str) -> dict[str, str] | None:
    path = weights_folder(name) / POLICY_FILE
    if not path.is_file():
        return None
    shown = path.relative_to(ROOT) if path.is_relative_to(ROOT) else path
    return {"path": str(shown), "sha256": _sha256(path)}


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


# What a manifest's "tracked files differed" leaves out: the documentation, where the results are published.
# `make results` writes each result there before the next is raced; those files are no code the races ran.
DOCUMENTATION_EXCLUDES = (":(exclude)docs", ":(exclude)README.md")


@lru_cache(maxsize=1)
def source_commit() -> tuple[str, bool | None]:
    """The git commit of the code this process runs and whether tracked files other than the documentation
    (:data:`DOCUMENTATION_EXCLUDES`) differ from it. Outside a checkout
    (an image, a copy of the tree): the commit named by :data:`COMMIT_VARIABLE` if set, else ``"unknown"``; whether
    files differ is then unknown (``None``). Asked once per process: the code loaded is the code it started with."""
    try:
        top = _git("rev-parse", "--show-toplevel")
        if Path(top).resolve() != ROOT:
            raise OSError(f"{ROOT} is not the top of a checkout")  # installed inside some other repository
        commit = _git("rev-parse", "HEAD")
        changed = _git("status", "--porcelain", "--untracked-files=no", "--", ".", *DOCUMENTATION_EXCLUDES)
    except (OSError, subprocess.SubprocessError):
        return os.environ.get(COMMIT_VARIABLE) or UNKNOWN, None
    return commit, bool(changed)


def _git(*args: str) -> str:
    done = subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True, timeout=10, check=True)
    return done.stdout.strip()


def machine() -> dict[str, Any]:
    """Where it ran: Python, platform, processor and CPUs."""
    return {
        "python": platform.python_version(),
        "platform": platform.platform(),
        "processor": platform.machine(),
        "cpus": os.cpu_count(),
    }


def build_manifest(kind: str, agents: Sequence[AgentManifest], preset: str, conditions: Mapping[str, Any]) -> Manifest:
    """A manifest of this process's code and machine for ``agents`` racing in ``conditions``."""
    commit, dirty = source_commit()
    values = asdict(kart_preset(preset))
    return Manifest(kind, commit, dirty, tuple(agents), preset, values, dict(conditions), machine())


def time_limit_of(time_limit: float | None) -> float:
    """[s] the race's time limit: ``time_limit``, or the rules' when ``None``."""
    return float(time_limit) if time_limit is not None else RuleParams().time_limit


def race_manifest(
    spec: RaceSpec, background_planners: Sequence[str] = (), background_planner: Mapping[str, Any] | None = None
) -> Manifest:
    """The manifest of headless race ``spec`` (``background_planners``: its agents given an MCTS planner with
    the settings ``background_planner`` in the background, for their Δr and Δv only:
    :func:`arena.race.with_background_planner`)."""
    laps = spec.laps if spec.laps is not None else load_any_track(spec.track).laps
    conditions = {
        "track": spec.track,
        "laps": laps,
        "start_lanes": list(grid_lanes(len(spec.controllers), spec.start_lanes)),
        "conditions": spec.drawn().to_json(),
        "plan_latency": spec.plan_latency,
        "seed": spec.seed,
        "time_limit": time_limit_of(spec.time_limit),
        "background_planners": list(background_planners),
        "background_planner": dict(background_planner) if background_planners and background_planner else None,
    }
    return build_manifest("race", [describe_agent(a) for a in spec.controllers], spec.kart_preset, conditions)


def stale_agents(recorded: Manifest, lookup: SpecLookup = controller_spec) -> list[str]:
    """How the agents of ``recorded`` differ from the same agent strings resolved now (empty: they are the same):
    a controller no longer registered, a parameter added, removed or with another value (a changed default), or
    other trained weights. The kart preset's values are compared too."""
    problems = []
    for agent in recorded.agents:
        if agent.name == HUMAN:
            continue
        try:
            now = describe_agent(agent.agent, lookup)
        except KeyError:
            problems.append(f"{agent.agent}: controller {agent.name!r} is no longer registered")
            continue
        except ValueError as exc:
            problems.append(f"{agent.agent}: no longer valid ({exc})")
            continue
        for key in agent.parameters:
            if key not in now.parameters:
                problems.append(f"{agent.agent}: {key} is no longer a parameter")
            elif _differ(agent.parameters[key], now.parameters[key]):
                problems.append(f"{agent.agent}: {key} was {agent.parameters[key]!r}, is {now.parameters[key]!r} now")
        for key in now.parameters:
            if key not in agent.parameters:
                problems.append(f"{agent.agent}: {key} = {now.parameters[key]!r} is a new parameter")
        if (agent.weights or {}).get("sha256") != (now.weights or {}).get("sha256"):
            problems.append(
                f"{agent.agent}: its trained weights changed ({_short(agent.weights)} -> {_short(now.weights)})"
            )
    try:
        kart = asdict(kart_preset(recorded.kart_preset))
    except ValueError:
        problems.append(f"kart preset {recorded.kart_preset!r} is no longer defined")
    else:
        if recorded.kart and dict(recorded.kart) != kart:
            changed = sorted(k for k in set(kart) | set(recorded.kart) if kart.get(k) != recorded.kart.get(k))
            problems.append(f"kart preset {recorded.kart_preset!r}: {', '.join(changed)} changed")
    return problems


def _differ(was: object, now: object) -> bool:
    return was != now or type(was) is not type(now)  # True == 1 == 1.0, yet a bool is not a number here


def _short(weights: Mapping[str, str] | None) -> str:
    return "none" if not weights else weights["sha256"][:12]
