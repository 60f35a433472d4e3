"""Server configuration: every knob of the race server, read from ``KARTING_*`` environment variables."""

from __future__ import annotations

import ipaddress
import json
from typing import Annotated, Any

from pydantic import Field, SecretStr, field_validator
from pydantic_settings import BaseSettings, NoDecode, SettingsConfigDict

LOOPBACK_HOSTS = ("localhost", "127.0.0.1", "::1")

# a list setting from the environment: comma-separated (``a.example,b.example``) or a JSON list
NameList = Annotated[list[str], NoDecode]


class Settings(BaseSettings):
    """Race server settings (environment prefix ``KARTING_``, e.g. ``KARTING_PORT=9000``)."""

    model_config = SettingsConfigDict(env_prefix="KARTING_", extra="ignore")

    host: str = "127.0.0.1"
    port: int = Field(default=8000, ge=0, le=65535)
    database_url: str = "sqlite:///./karting.db"  # SQLite files are opened in WAL mode
    max_sessions: int = Field(default=16, ge=1, description="races live at once (starting, waiting or running)")
    max_laps: int = Field(default=20, ge=1)
    tournament_workers: int = Field(default=1, ge=1, description="worker processes racing each tournament's races")
    max_tournaments: int = Field(default=1, ge=1, description="tournaments running at once")
    viewer_enabled: bool = True  # one 3D scene (viser) per race, served under /races/{id}/viewer/
    plan_workers: int = Field(default=1, ge=1, description="planner worker processes shared by every race")
    controller_hosts: int = Field(
        default=1,
        ge=0,
        description="processes running the AI controllers (0: a thread per AI kart in the server process)",
    )
    speedup: float = Field(
        default=1.0, gt=0.0, le=100.0, description="tick rate as a multiple of 50 Hz (tests); 1 = real time"
    )
    drive_timeout_s: float = Field(
        default=0.5, gt=0.0, description="[s] wall time without driver input before the kart brakes"
    )
    # the one statement of how long a race waits for its drivers: pages and documents cite the setting's name
    human_wait_s: float = Field(
        default=60.0,
        ge=0.0,
        description="[s] a race waits this long for its human drivers to connect, then is cancelled",
    )
    view_ready_wait_s: float = Field(
        default=30.0,
        ge=0.0,
        description="[s] once every human driver is connected, the race waits this long for their views to load",
    )
    countdown_s: float = Field(
        default=3.0, ge=0.0, le=10.0, description="[s] countdown before a race with human drivers starts"
    )
    controller_hold_s: float = Field(
        default=0.5, ge=0.0, description="[s] race time a kart holds its input without a fresh one, then brakes"
    )
    controller_hang_s: float = Field(
        default=1.0, gt=0.0, description="[s] wall time after which an unanswered controller call is hung"
    )
    controller_reset_s: float = Field(default=20.0, gt=0.0, description="[s] wall time allowed for a driver's reset")
    lockstep: bool = Field(
        default=False,
        description="each tick waits (up to controller_hang_s) for every AI kart's answer to the observation it "
        "was handed and for every plan due: a live race is then the headless race of its seed, its ticks "
        "stretching when a controller is slow (default: never wait; a late answer is a missed deadline)",
    )
    plan_budget_s: float = Field(
        default=0.3,
        gt=0.0,
        description="[s] wall time a planner that can cut a plan short (a TimeBoundedPlanner) spends on one",
    )
    plan_timeout_s: float = Field(
        default=10.0, gt=0.0, description="[s] wall time after which a plan request is given up"
    )
    telemetry_hz: float = Field(default=25.0, gt=0.0, le=50.0, description="[Hz] telemetry messages per second")
    keep_finished_s: float = Field(
        default=60.0, ge=0.0, description="[s] a finished race stays in memory (scene, sockets) this long"
    )
    max_replays: int = Field(default=4, ge=1, description="replay scenes (3D) open at once")
    replay_idle_s: float = Field(
        default=120.0, gt=0.0, description="[s] a replay scene without viewers is closed after this long"
    )
    realtime_priority: int = Field(
        default=0,
        ge=0,
        le=99,
        description="SCHED_FIFO priority of the server's threads (0: ordinary scheduling; needs CAP_SYS_NICE)",
    )
    switch_interval_s: float = Field(
        default=0.0005, gt=0.0, description="[s] sys.setswitchinterval: how long a busy thread may keep the GIL"
    )

    # ---- connections: idle and half-open ones time out; websocket messages are bounded (see server.routes.sockets)
    keep_alive_timeout_s: float = Field(
        default=5.0, gt=0.0, description="[s] an idle HTTP keep-alive connection is closed after this long"
    )
    ws_ping_interval_s: float = Field(
        default=20.0, gt=0.0, description="[s] the server pings every websocket this often"
    )
    ws_ping_timeout_s: float = Field(
        default=20.0, gt=0.0, description="[s] a websocket whose ping is not answered this long is closed"
    )
    ws_max_message_bytes: int = Field(
        default=1 << 20,
        ge=1024,
        description="[bytes] the largest websocket message any socket accepts (each socket has a smaller limit)",
    )
    # ---- races that nobody can finish
    abandoned_race_s: float = Field(
        default=5.0,
        ge=0.0,
        description="[s] a race ends (the rest not finished) once no unfinished kart could move for this long: "
        "every one an absent or silent human, or an AI whose controller was disabled",
    )
    # ---------------------------------------------------------------- the edge: exposed deployments (server.edge)
    max_body_bytes: int = Field(
        default=64 * 1024, ge=1024, description="[bytes] larger request bodies are refused with 413 before parsing"
    )
    api_key: SecretStr | None = Field(
        default=None,
        description="when set, creating and stopping races and tournaments needs this key in the X-API-Key header",
    )
    allowed_hosts: NameList | None = Field(
        default=None,
        description="Host header names served (HTTP and websockets; '*' any, '*.example.org' subdomains); "
        "default: the loopback names when bound to a loopback address, any otherwise",
    )
    allowed_origins: NameList = Field(
        default_factory=list,
        description="Origin headers accepted besides those on an allowed host (e.g. https://karts.example.org)",
    )
    cors_origins: NameList = Field(
        default_factory=list, description="origins given CORS access to the API (default: none, no CORS headers)"
    )

    @field_validator("allowed_hosts", "allowed_origins", "cors_origins", mode="before")
    @classmethod
    def _comma_separated(cls, value: Any) -> Any:
        if isinstance(value, str):
            value = value.strip()
            if value.startswith("["):
                return json.loads(value)
            return [part.strip() for part in value.split(",") if part.strip()]
        return value

    @classmethod
    def env_name(cls, field: str) -> str:
        """The environment variable that sets ``field`` (``human_wait_s``: ``KARTING_HUMAN_WAIT_S``)."""
        if field not in cls.model_fields:
            raise KeyError(field)
        return (cls.model_config.get("env_prefix", "") + field).upper()

    def served_hosts(self) -> list[str]:
        """The Host names served: ``allowed_hosts``, or by default the loopback names when bound to loopback and
        any host (``*``) otherwise."""
        if self.allowed_hosts is not None:
            return [h.lower() for h in self.allowed_hosts]
        if is_loopback(self.host):
            return list(LOOPBACK_HOSTS)
        return ["*"]


def is_loopback(host: str) -> bool:
    """Whether ``host`` (a name or address to bind or serve) is this machine's loopback."""
    name = host.strip("[]").lower()
    if name == "localhost":
        return True
    try:
        return ipaddress.ip_address(name).is_loopback
    except ValueError:
        return False
