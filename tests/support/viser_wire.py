"""viser's wire protocol for tests without a browser: a websocket client to a scene, its frames decoded to
messages, and race frames to show.

Each viser websocket frame is ``u64 len(msgpack) | u64 len(zstd) | zstd(msgpack {"messages": [...]}) | binary
buffers``; the tests decode the messages and look at their types, node names and props.
"""

from __future__ import annotations

import asyncio
import time
from collections.abc import Callable
from typing import Any

import msgspec
import viser
import websockets
import zstandard
from websockets.typing import Subprotocol

from sim_core.track import Track
from web.frame import KartFrame, RaceFrame

SUBPROTOCOL = Subprotocol(f"viser-v{viser.__version__}")
Message = dict[str, Any]


def decode_frame(data: bytes) -> list[Message]:
    """The messages of one viser websocket frame."""
    inner_size = int.from_bytes(data[:8], "little")
    compressed_size = int.from_bytes(data[8:16], "little")
    inner = zstandard.ZstdDecompressor().decompress(data[16 : 16 + compressed_size], max_output_size=inner_size)
    return list(msgspec.msgpack.decode(inner)["messages"])


async def receive_until(
    ws: websockets.ClientConnection, done: Callable[[list[Message]], bool], timeout: float = 10.0
) -> list[Message]:
    """Collect messages until ``done(all so far)`` holds (or fail after ``timeout`` seconds)."""
    messages: list[Message] = []
    deadline = time.monotonic() + timeout
    while not done(messages):
        remaining = deadline - time.monotonic()
        assert remaining > 0, f"timed out; got {sorted({m['type'] for m in messages})}"
        data = await asyncio.wait_for(ws.recv(), remaining)
        assert isinstance(data, bytes)
        messages.extend(decode_frame(data))
    return messages


def replay_done(messages: list[Message]) -> bool:
    """Whether viser finished sending its scene backlog."""
    return any(m["type"] == "ReplayDoneMessage" for m in messages)


def named(messages: list[Message], kind: str) -> dict[str, Message]:
    """Last message of type ``kind`` per node name."""
    return {m["name"]: m for m in messages if m["type"] == kind}


def make_frame(
    track: Track,
    n_karts: int,
    *,
    step: int = 0,
    plans_version: int = 0,
    moved: float = 0.0,
    waypoints: tuple[tuple[float, float], ...] = (),
    predicted: tuple[tuple[float, float], ...] = (),
    status: str = "running",
) -> RaceFrame:
    """A frame with karts on the grid (kart 0 ``moved`` metres along x) and kart 0's plan."""
    karts = []
    for i in range(n_karts):
        point = track.lane_point(0, 1 + i % track.n_lanes)
        karts.append(
            KartFrame(
                index=i,
                name=f"Driver {i}",
                controller="fixed-lqng",
                x=float(point[0]) + (moved if i == 0 else 0.0),
                y=float(point[1]),
                heading=0.3 * i,
                speed=5.0 + i,
                steer=0.0,
                throttle=1.0,
                lap=1,
                position=i + 1,
                checkpoints_passed=0,
                lane=1 + i % track.n_lanes,
                collisions_at_fault=i,
                illegal_lane_changes=0,
                wall_hits=0,
                finished=False,
                finish_time=None,
                controller_faults=0,
                waypoints=waypoints if i == 0 else (),
                predicted=predicted if i == 0 else (),
            )
        )
    return RaceFrame("r1", track.name, step * 0.02, step, track.laps, status, tuple(karts), plans_version)


def connect(port: int, path: str = "", subprotocol: str = SUBPROTOCOL) -> Any:
    """A websocket client to ``ws://127.0.0.1:port/path`` speaking ``subprotocol``."""
    return websockets.connect(
        f"ws://127.0.0.1:{port}{path}", subprotocols=[Subprotocol(subprotocol)], max_size=None, compression=None
    )
