"""Tick timing of the race server under load, measured from outside through its API.

Starts ``karting serve`` (a subprocess: real uvicorn, one worker, the 3D view on) on a temporary database,
then for 1, 4 and 8 concurrent races of MCTS-LQNG vs Fixed-LQNG on the oval (so one kart per race uses the
MCTS planner worker), each watched by a telemetry websocket client and a viser (3D view) websocket client,
measures over a window of ticks:

* jitter = |tick start - scheduled deadline| (p50, p99 over every tick of every race in the window) [ms];
* overruns (ticks that started more than one period late) and the controllers' missed deadlines;

and finally, with one human race, how many ticks after sending an input on the drive websocket the state
message reflecting it arrives (``drive_reflect_ticks``, median; the input is applied at the next tick).

Run from the repo root: ``.venv/bin/python benchmarks/serve_loop.py`` (about a minute and a half; ``--help``: the
load levels, windows and inputs). The last line printed is one JSON object.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import os
import socket
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import viser
from websockets.asyncio.client import ClientConnection, connect

from server.status import LIVE_STATUSES, RaceStatus

ROOT = Path(__file__).resolve().parents[1]
RACE = {"track": "oval", "laps": 4, "karts": [{"controller": "mcts-lqng"}, {"controller": "fixed-lqng"}]}
HUMAN_RACE = {"track": "oval", "laps": 4, "karts": [{"controller": "human"}, {"controller": "lane-follower"}]}


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port: int = s.getsockname()[1]
        return port


async def read_forever(ws: ClientConnection) -> None:
    """A viewer that reads (and drops) everything it is sent."""
    with contextlib.suppress(Exception):
        async for _ in ws:
            pass


async def wait_running(client: httpx.AsyncClient, race_id: str) -> None:
    """Wait until the race runs, through whatever comes before (a race with a human kart waits for its driver and
    counts down); raises if it ended instead."""
    while (status := (await client.get(f"/api/races/{race_id}")).json()["status"]) != RaceStatus.RUNNING:
        if status not in LIVE_STATUSES:
            raise RuntimeError(f"race {race_id} is {status}, not running")
        await asyncio.sleep(0.1)


async def measure(client: httpx.AsyncClient, ws_url: str, n: int, settle: float, window: float) -> dict[str, Any]:
    """Jitter, overruns and missed deadlines of ``n`` concurrent races with two viewers each."""
    races = [(await client.post("/api/races", json={**RACE, "seed": i})).json() for i in range(n)]
    viewers = []
    for race in races:
        viewers.append(await connect(f"{ws_url}{race['telemetry_url']}", max_size=None))
        if race["viewer_url"]:
            viewers.append(
                await connect(
                    f"{ws_url}/races/{race['id']}/viewer",
                    subprotocols=[f"viser-v{viser.__version__}"],  # type: ignore[list-item]
                    max_size=None,
                )
            )
    readers = [asyncio.create_task(read_forever(ws)) for ws in viewers]
    await asyncio.gather(*(wait_running(client, r["id"]) for r in races))
    await asyncio.sleep(settle)  # let the last race's start-up (world, racing line, planner) pass

    async def snapshot() -> list[dict[str, Any]]:
        return [(await client.get(f"/api/races/{r['id']}")).json() for r in races]

    before = await snapshot()
    canary = await asyncio.create_subprocess_exec(
        sys.executable, __file__, "--canary", str(window), stdout=asyncio.subprocess.PIPE
    )
    await asyncio.sleep(window)
    ticks = [(await client.get(f"/api/races/{r['id']}/ticks")).json() for r in races]
    after = await snapshot()
    jitter: list[float] = []
    overruns = missed = 0
    for b, a, t in zip(before, after, ticks):
        done = a["tick_stats"]["ticks"] - b["tick_stats"]["ticks"]
        jitter.extend(t["recent_jitter_ms"][-done:])
        overruns += a["tick_stats"]["overruns"] - b["tick_stats"]["overruns"]
        missed += sum(x["missed_deadlines"] for x in a["drivers"]) - sum(x["missed_deadlines"] for x in b["drivers"])
    statuses = {a["status"] for a in after}
    canary_out, _ = await canary.communicate()
    for race in races:
        await client.post(f"/api/races/{race['id']}/stop")
    for ws in viewers:
        await ws.close()
    for task in readers:
        task.cancel()
    values = np.array(jitter)
    return {
        "ticks": len(jitter),
        "p50": float(np.percentile(values, 50)),
        "p99": float(np.percentile(values, 99)),
        "max": float(values.max()),
        "overruns": overruns,
        "missed": missed,
        "statuses": sorted(statuses),
        "viewers": len(viewers),
        "canary": json.loads(canary_out),
    }


async def drive_reflect(client: httpx.AsyncClient, ws_url: str, inputs: int) -> list[int]:
    """Ticks between sending an input and the state message that shows it applied, for ``inputs`` inputs."""
    race = (await client.post("/api/races", json=HUMAN_RACE)).json()
    delays = []
    async with connect(f"{ws_url}/api/races/{race['id']}/drive?kart=0&token={race['drive_tokens']['0']}") as ws:
        await wait_running(client, race["id"])
        last_step = -1
        sent: dict[int, int] = {}

        async def receive() -> None:
            nonlocal last_step
            async for raw in ws:
                message = json.loads(raw)
                if message["type"] != "state":
                    continue
                last_step = message["step"]
                seq = message["input_seq"]
                if seq in sent:
                    delays.append(last_step - sent.pop(seq))

        reader = asyncio.create_task(receive())
        await asyncio.sleep(0.5)
        for seq in range(inputs):
            sent[seq] = last_step
            await ws.send(json.dumps({"steer": 0.0, "throttle": 0.3, "seq": seq}))
            await asyncio.sleep(0.02)
        await asyncio.sleep(0.2)
        reader.cancel()
    await client.post(f"/api/races/{race['id']}/stop")
    return delays


def start_server(port: int, db: str, realtime: int) -> subprocess.Popen[bytes]:
    """``karting serve`` on ``port`` with the database ``db``."""
    env = {
        **os.environ,
        "KARTING_MAX_SESSIONS": "16",
        "KARTING_KEEP_FINISHED_S": "2",
        "KARTING_REALTIME_PRIORITY": str(realtime),
    }
    command = [sys.executable, "-m", "karting", "serve", "--port", str(port), "--db", db]
    return subprocess.Popen(command, cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)


async def wait_up(client: httpx.AsyncClient, server: subprocess.Popen[bytes]) -> float:
    """Seconds until the server answers."""
    started = time.monotonic()
    while True:
        with contextlib.suppress(httpx.TransportError):
            if (await client.get("/api/tracks")).status_code == 200:
                return time.monotonic() - started
        if server.poll() is not None or time.monotonic() - started > 180:
            raise RuntimeError(f"server did not start: {server.stderr.read().decode() if server.stderr else ''}")
        await asyncio.sleep(0.2)


def report(n: int, r: dict[str, Any]) -> None:
    """Print one load level's figures."""
    c = r["canary"]
    print(
        f"{n} race(s), {r['viewers']} viewer sockets, {r['ticks']} ticks: jitter p50 {r['p50']:.3f} ms, "
        f"p99 {r['p99']:.3f} ms, max {r['max']:.2f} ms; overruns {r['overruns']}; "
        f"controller missed deadlines {r['missed']}; statuses {r['statuses']}\n"
        f"  meanwhile a bare 50 Hz sleep loop in another process (the machine's own load): "
        f"p50 {c['p50']:.3f} ms, p99 {c['p99']:.3f} ms, max {c['max']:.2f} ms"
    )


async def run(args: argparse.Namespace) -> dict[str, Any]:
    """Every measurement; returns the JSON summary."""
    port = free_port()
    ws_url = f"ws://127.0.0.1:{port}"
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        server = start_server(port, f"{tmp}/bench.db", args.realtime)
        try:
            async with httpx.AsyncClient(base_url=f"http://127.0.0.1:{port}", timeout=30) as client:
                print(f"server up in {await wait_up(client, server):.1f} s (realtime priority {args.realtime})")
                for n in args.sessions:
                    results[n] = await measure(client, ws_url, n, args.settle, args.window)
                    report(n, results[n])
                    await asyncio.sleep(1.0)
                delays = await drive_reflect(client, ws_url, args.inputs)
                print(
                    f"drive input -> state reflecting it: median {statistics.median(delays)} ticks, "
                    f"max {max(delays)} ticks ({len(delays)} inputs)"
                )
        finally:
            server.terminate()
            server.wait(30)
    out: dict[str, Any] = {}
    for n, r in results.items():
        out[f"p50_jitter_ms_{n}_sessions"] = round(r["p50"], 3)
        out[f"p99_jitter_ms_{n}_sessions"] = round(r["p99"], 3)
        out[f"overruns_{n}_sessions"] = r["overruns"]
    out["drive_reflect_ticks"] = statistics.median(delays)
    return out


def canary(seconds: float) -> dict[str, float]:
    """Lateness of a bare 50 Hz sleep loop in its own process: what this machine's load alone does to timing."""
    late = []
    t0 = time.monotonic()
    n = 0
    while time.monotonic() - t0 < seconds:
        n += 1
        deadline = t0 + n * 0.02
        time.sleep(max(0.0, deadline - time.monotonic()))
        late.append((time.monotonic() - deadline) * 1e3)
    values = np.array(late)
    return {
        "p50": float(np.percentile(values, 50)),
        "p99": float(np.percentile(values, 99)),
        "max": float(values.max()),
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--sessions", type=lambda s: [int(x) for x in s.split(",")], default=[1, 4, 8])
    parser.add_argument("--window", type=float, default=10.0, help="[s] measured per load level")
    parser.add_argument("--settle", type=float, default=3.0, help="[s] after the races start, before measuring")
    parser.add_argument("--inputs", type=int, default=200, help="drive inputs sent to measure the reflection")
    parser.add_argument("--realtime", type=int, default=0, help="the server's KARTING_REALTIME_PRIORITY (0: off)")
    parser.add_argument("--canary", type=float, default=None, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.canary is not None:
        print(json.dumps(canary(args.canary)))
        return
    print(json.dumps(asyncio.run(run(args))))


if __name__ == "__main__":
    main()
