"""Soak test of the race server: many races, viewers and drivers for a long time, on loopback only.

Starts ``karting serve`` (a subprocess on 127.0.0.1, temporary database) and keeps, for ``--duration`` seconds:

* ``--races`` concurrent races (default 8): ``--drivers`` of them (default 4) with a human kart driven over the
  drive websocket at 50 Hz by a scripted client, the others AI against AI; a race that ends is replaced;
* ``--viewers`` telemetry websocket clients (default 20) spread over the races, moving on when theirs ends.

Then prints, from the server's own tick records (every tick of every race): the tick jitter (|start - deadline|)
p50/p99/max, the ticks later than 5 ms, the server's overruns, the missed controller deadlines per kart, the
server's memory (its process and its workers) at the start of the measurement and at the end (growth in %), and
error counts (HTTP errors, abnormal websocket closes, error messages to drivers, races that did not finish or
stop normally, error lines in the server's log). A bare 50 Hz sleep loop in another process measures what the
machine's own load does to timing (``canary``).

Bounded: at most ``--max-races`` races are created in all, and the run ends after ``--duration`` seconds.
Run from the repo root: ``.venv/bin/python benchmarks/soak.py --duration 600`` (the default: 10 minutes).
The last line printed is one JSON object.
"""

from __future__ import annotations

import argparse
import asyncio
import contextlib
import json
import os
import random
import socket
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import httpx
import numpy as np
import psutil
from websockets.asyncio.client import connect
from websockets.exceptions import ConnectionClosed

from server.status import LIVE_STATUSES

ROOT = Path(__file__).resolve().parents[1]
LOOPBACK = "127.0.0.1"
AI_RACE = {"track": "oval", "laps": 20, "karts": [{"controller": "fixed-lqng"}, {"controller": "lane-follower"}]}
HUMAN_RACE = {"track": "oval", "laps": 20, "karts": [{"controller": "human"}, {"controller": "lane-follower"}]}
LATE_MS = 5.0  # [ms] a tick starting later than this counts as late
LIVE = LIVE_STATUSES  # a race with a human kart waits for its driver and counts down before it runs
NORMAL_ENDS = ("finished", "stopped")


@dataclass
class Counters:
    """What went wrong, and what was done."""

    http_errors: int = 0
    ws_abnormal_closes: int = 0
    driver_error_messages: int = 0
    races_created: int = 0
    races_ended_abnormally: int = 0
    inputs_sent: int = 0
    frames_received: int = 0
    ended: dict[str, str] = field(default_factory=dict)  # race id -> final status


class Soak:
    """The load, the samples and the counters of one soak run against the server at ``port``."""

    def __init__(self, client: httpx.AsyncClient, port: int, args: argparse.Namespace) -> None:
        self.client = client
        self.ws_url = f"ws://{LOOPBACK}:{port}"
        self.args = args
        self.counters = Counters()
        self.rng = random.Random(14)
        self.stop = asyncio.Event()
        self.races: dict[str, bool] = {}  # live race id -> has a human kart
        self.seen_ticks: dict[str, int] = {}  # race id -> ticks already collected
        self.seen_overruns: dict[str, int] = {}  # race id -> overruns already counted
        self.jitter_ms: list[float] = []
        self.overruns = 0
        self.missed: dict[str, int] = {}  # "race/kart" -> missed controller deadlines

    async def request(self, method: str, url: str, **kwargs: Any) -> dict[str, Any] | None:
        """An API call; a transport error or an error status is counted (None)."""
        try:
            response = await self.client.request(method, url, **kwargs)
        except httpx.TransportError:
            self.counters.http_errors += 1
            return None
        if response.status_code >= 400:
            self.counters.http_errors += 1
            return None
        body: dict[str, Any] = response.json()
        return body

    async def create(self, human: bool) -> dict[str, Any] | None:
        """A new race (None once ``--max-races`` were created)."""
        if self.counters.races_created >= self.args.max_races:
            return None
        self.counters.races_created += 1
        body = {**(HUMAN_RACE if human else AI_RACE), "seed": self.counters.races_created}
        race = await self.request("POST", "/api/races", json=body)
        if race is not None:
            self.races[race["id"]] = human
        return race

    # ------------------------------------------------------------------ load
    async def ai_races(self, n: int) -> None:
        """Keep ``n`` AI races running."""
        running: list[str] = []
        while not self.stop.is_set():
            for race_id in list(running):
                if race_id not in self.races:
                    running.remove(race_id)
            while len(running) < n and not self.stop.is_set():
                race = await self.create(human=False)
                if race is None:
                    return
                running.append(race["id"])
            await asyncio.sleep(0.5)

    async def driver(self) -> None:
        """One scripted driver: drives a human race at 50 Hz until it ends, then starts another."""
        while not self.stop.is_set():
            race = await self.create(human=True)
            if race is None:
                return
            url = f"{self.ws_url}/api/races/{race['id']}/drive?kart=0&token={race['drive_tokens']['0']}"
            try:
                async with connect(url, open_timeout=30) as ws:
                    reader = asyncio.create_task(self._read_driver(ws))
                    seq = 0
                    while not reader.done() and not self.stop.is_set():
                        seq += 1
                        steer = 0.3 * np.sin(seq / 50.0)
                        await ws.send(json.dumps({"steer": steer, "throttle": 0.6, "seq": seq}))
                        self.counters.inputs_sent += 1
                        await asyncio.sleep(0.02)
                    reader.cancel()
                    with contextlib.suppress(asyncio.CancelledError):
                        await reader
            except ConnectionClosed as exc:
                if exc.rcvd is None or exc.rcvd.code not in (1000, 1001):
                    self.counters.ws_abnormal_closes += 1
            except OSError:
                self.counters.ws_abnormal_closes += 1

    async def _read_driver(self, ws: Any) -> None:
        async for raw in ws:
            message = json.loads(raw)
            if message["type"] == "error":
                self.counters.driver_error_messages += 1
            elif message["type"] == "end":
                return

    async def viewer(self) -> None:
        """One telemetry client: watches a random live race, then another when it ends."""
        while not self.stop.is_set():
            if not self.races:
                await asyncio.sleep(0.2)
                continue
            race_id = self.rng.choice(sorted(self.races))
            try:
                async with connect(f"{self.ws_url}/api/races/{race_id}/telemetry", open_timeout=30) as ws:
                    while not self.stop.is_set():
                        try:
                            await asyncio.wait_for(ws.recv(), 1.0)
                        except TimeoutError:
                            continue
                        self.counters.frames_received += 1
            except ConnectionClosed as exc:
                if exc.rcvd is None or exc.rcvd.code not in (1000, 1001, 4404):
                    self.counters.ws_abnormal_closes += 1
            except OSError:
                self.counters.ws_abnormal_closes += 1
            await asyncio.sleep(0.5)  # its race ended: the next sample forgets it

    # ------------------------------------------------------------------ measurement
    async def sample(self, measuring: bool) -> None:
        """Collect every race's new ticks and fault counts; forget races that ended."""
        for race_id in list(self.races):
            ticks = await self.request("GET", f"/api/races/{race_id}/ticks")
            detail = await self.request("GET", f"/api/races/{race_id}")
            if ticks is None or detail is None or ticks["stats"] is None:
                if detail is not None and detail["status"] not in LIVE:
                    self._ended(race_id, detail["status"])
                continue
            done, overruns = ticks["stats"]["ticks"], ticks["stats"]["overruns"]
            # a race first seen while measuring counts from its start; one seen before, from then on
            new = done - self.seen_ticks.get(race_id, 0 if measuring else done)
            new_overruns = overruns - self.seen_overruns.get(race_id, 0 if measuring else overruns)
            self.seen_ticks[race_id], self.seen_overruns[race_id] = done, overruns
            if measuring:
                if new > 0:
                    self.jitter_ms.extend(ticks["recent_jitter_ms"][-new:])
                self.overruns += new_overruns
                for d in detail["drivers"]:
                    if d["controller"] != "human":
                        self.missed[f"{race_id}/{d['index']}"] = d["missed_deadlines"]
            if detail["status"] not in LIVE:
                self._ended(race_id, detail["status"])

    def _ended(self, race_id: str, status: str) -> None:
        self.races.pop(race_id, None)
        self.counters.ended[race_id] = status
        if status not in NORMAL_ENDS:
            self.counters.races_ended_abnormally += 1


def free_port() -> int:
    """A TCP port free on loopback now."""
    with socket.socket() as sock:
        sock.bind((LOOPBACK, 0))
        port: int = sock.getsockname()[1]
        return port


def memory(pid: int) -> int:
    """[bytes] resident memory of ``pid`` and its descendants (planner worker, controller hosts)."""
    process = psutil.Process(pid)
    total = 0
    for p in [process, *process.children(recursive=True)]:
        with contextlib.suppress(psutil.Error):
            total += p.memory_info().rss
    return total


def canary(seconds: float) -> dict[str, float]:
    """Lateness [ms] of a bare 50 Hz sleep loop in its own process: the machine's own timing noise."""
    late = []
    t0 = time.monotonic()
    n = 0
    while time.monotonic() - t0 < seconds:
        n += 1
        deadline = t0 + n * 0.02
        time.sleep(max(0.0, deadline - time.monotonic()))
        late.append((time.monotonic() - deadline) * 1e3)
    values = np.array(late)
    return {"p99_ms": round(float(np.percentile(values, 99)), 3), "max_ms": round(float(values.max()), 2)}


async def soak(args: argparse.Namespace) -> dict[str, Any]:
    """The whole run; returns the JSON summary."""
    port = free_port()
    with tempfile.TemporaryDirectory() as tmp:
        log_path = Path(tmp) / "server.log"
        # a finished race stays in memory past the next sample, so its last ticks are counted
        keep = str(args.sample + 5)
        env = {**os.environ, "KARTING_MAX_SESSIONS": str(args.races + 4), "KARTING_KEEP_FINISHED_S": keep}
        command = [sys.executable, "-m", "karting", "serve", "--host", LOOPBACK, "--port", str(port)]
        command += ["--db", f"{tmp}/soak.db"]
        with log_path.open("wb") as log:
            server = subprocess.Popen(command, cwd=ROOT, env=env, stdout=log, stderr=subprocess.STDOUT)
        try:
            async with httpx.AsyncClient(base_url=f"http://{LOOPBACK}:{port}", timeout=30) as client:
                started = time.monotonic()
                while True:
                    with contextlib.suppress(httpx.TransportError):
                        if (await client.get("/api/tracks")).status_code == 200:
                            break
                    if server.poll() is not None or time.monotonic() - started > 180:
                        raise RuntimeError("the server did not start:\n" + log_path.read_text()[-3000:])
                    await asyncio.sleep(0.2)
                print(f"server up in {time.monotonic() - started:.1f} s on {LOOPBACK}:{port}", flush=True)
                result = await _run_load(Soak(client, port, args), server.pid, args)
        finally:
            server.terminate()
            try:
                server.wait(30)
            except subprocess.TimeoutExpired:
                server.kill()
        log_text = log_path.read_text(errors="replace")
    result["errors"]["server_log_error_lines"] = sum(
        1 for line in log_text.splitlines() if "ERROR" in line or "Traceback" in line
    )
    result["errors_total"] = sum(result["errors"].values())
    return result


async def _run_load(run: Soak, pid: int, args: argparse.Namespace) -> dict[str, Any]:
    tasks = [asyncio.create_task(run.ai_races(args.races - args.drivers))]
    tasks += [asyncio.create_task(run.driver()) for _ in range(args.drivers)]
    tasks += [asyncio.create_task(run.viewer()) for _ in range(args.viewers)]
    await asyncio.sleep(args.settle)
    await run.sample(measuring=False)
    baseline = memory(pid)
    measure_start = time.monotonic()
    canary_process = await asyncio.create_subprocess_exec(
        sys.executable, __file__, "--canary", str(args.duration), stdout=asyncio.subprocess.PIPE
    )
    peak = baseline
    while time.monotonic() - measure_start < args.duration:
        await asyncio.sleep(args.sample)
        await run.sample(measuring=True)
        peak = max(peak, memory(pid))
        elapsed = time.monotonic() - measure_start
        print(
            f"{elapsed:6.0f} s: {len(run.races)} races live, {len(run.jitter_ms)} ticks, "
            f"memory {memory(pid) / 2**20:.0f} MiB, errors {_errors(run)}",
            flush=True,
        )
    end_memory = memory(pid)
    run.stop.set()
    for task in tasks:
        task.cancel()
    await asyncio.gather(*tasks, return_exceptions=True)
    machine, _ = await canary_process.communicate()
    values = np.array(run.jitter_ms or [0.0])
    per_kart = list(run.missed.values()) or [0]
    return {
        "duration_s": round(time.monotonic() - measure_start, 1),
        "races": args.races,
        "viewers": args.viewers,
        "drivers": args.drivers,
        "races_created": run.counters.races_created,
        "ticks": len(run.jitter_ms),
        "tick_jitter_p50_ms": round(float(np.percentile(values, 50)), 3),
        "tick_jitter_p99_ms": round(float(np.percentile(values, 99)), 3),
        "tick_jitter_max_ms": round(float(values.max()), 2),
        "ticks_later_than_5ms": int((values > LATE_MS).sum()),
        "overruns": run.overruns,
        "missed_deadlines_per_kart": {
            "karts": len(run.missed),
            "mean": round(float(np.mean(per_kart)), 2),
            "max": int(max(per_kart)),
            "total": int(sum(per_kart)),
        },
        "memory_mib_start": round(baseline / 2**20, 1),
        "memory_mib_end": round(end_memory / 2**20, 1),
        "memory_mib_peak": round(peak / 2**20, 1),
        "memory_growth_pct": round(100.0 * (end_memory - baseline) / baseline, 2),
        "inputs_sent": run.counters.inputs_sent,
        "frames_received": run.counters.frames_received,
        "errors": _errors(run),
        "canary": json.loads(machine),
    }


def _errors(run: Soak) -> dict[str, int]:
    c = run.counters
    return {
        "http": c.http_errors,
        "ws_abnormal_closes": c.ws_abnormal_closes,
        "driver_error_messages": c.driver_error_messages,
        "races_ended_abnormally": c.races_ended_abnormally,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=(__doc__ or "").split("\n\n")[0])
    parser.add_argument("--duration", type=float, default=600.0, help="[s] measured (after --settle)")
    parser.add_argument("--settle", type=float, default=20.0, help="[s] from the start of the load to the baseline")
    parser.add_argument("--sample", type=float, default=10.0, help="[s] between samples (< 60: 3,000 ticks kept)")
    parser.add_argument("--races", type=int, default=8, help="concurrent races")
    parser.add_argument("--drivers", type=int, default=4, help="of them with a websocket driver")
    parser.add_argument("--viewers", type=int, default=20, help="telemetry websocket clients")
    parser.add_argument("--max-races", type=int, default=500, help="races created at most in all")
    parser.add_argument("--canary", type=float, default=None, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.canary is not None:
        print(json.dumps(canary(args.canary)))
        return
    if not 0 <= args.drivers <= args.races or args.sample >= 60:
        parser.error("give 0 <= --drivers <= --races and --sample < 60")
    print(json.dumps(asyncio.run(soak(args))))


if __name__ == "__main__":
    main()
