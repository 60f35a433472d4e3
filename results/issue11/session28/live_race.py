"""One live race through the real server: mcts-lqng (default: the gated rollout check) from lane 2 of complex
against fixed-lqng, with the live plan budget ``KARTING_PLAN_BUDGET_S`` given on the command line (one planner
worker, the default). Prints one JSON line: finish times, plans applied per kart, tick overruns.

    .venv/bin/python results/issue11/session28/live_race.py 0.3
"""

from __future__ import annotations

import asyncio
import json
import os
import subprocess
import sys
import tempfile
import time

import httpx

sys.path.insert(0, os.getcwd())
from benchmarks.serve_loop import free_port, wait_up

RACE = {
    "track": "complex",
    "seed": 0,
    "start_lanes": [2, 3],
    "karts": [{"controller": "mcts-lqng"}, {"controller": "fixed-lqng"}],
}


async def main(budget: str) -> None:
    port = free_port()
    with tempfile.TemporaryDirectory() as tmp:
        env = {**os.environ, "KARTING_PLAN_BUDGET_S": budget, "KARTING_KEEP_FINISHED_S": "30"}
        command = [sys.executable, "-m", "karting", "serve", "--port", str(port), "--db", f"{tmp}/live.db"]
        server = subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        try:
            async with httpx.AsyncClient(base_url=f"http://127.0.0.1:{port}", timeout=60) as client:
                print(f"server up in {await wait_up(client, server):.1f} s", file=sys.stderr, flush=True)
                race = (await client.post("/api/races", json=RACE)).json()
                print(race, file=sys.stderr, flush=True)
                started = time.monotonic()
                detail = {}
                while time.monotonic() - started < 400:
                    detail = (await client.get(f"/api/races/{race['id']}")).json()
                    print(detail["status"], detail.get("step"), file=sys.stderr, flush=True)
                    if detail["status"] not in ("starting", "running"):
                        break
                    await asyncio.sleep(2.0)
                result = (await client.get(f"/api/races/{race['id']}/result")).json()
                row = {
                    "budget_s": float(budget),
                    "status": detail["status"],
                    "winner": result.get("winner"),
                    "time": [k.get("finish_time") for k in result.get("karts", [])],
                    "faults": [k.get("collisions_at_fault") for k in result.get("karts", [])],
                    "plans_applied": [d["plans_applied"] for d in detail["drivers"]],
                    "controller_faults": [d["controller_faults"] for d in detail["drivers"]],
                    "tick_stats": detail.get("tick_stats"),
                }
                print(json.dumps(row), flush=True)
        finally:
            server.terminate()
            server.wait(timeout=30)


if __name__ == "__main__":
    asyncio.run(main(sys.argv[1] if len(sys.argv) > 1 else "0.3"))
