"""Drive a kart from a program: start a race with one human kart against an AI, drive it over the websocket,
print the result.

Start a server first (``.venv/bin/karting serve``), then from the repo root::

    .venv/bin/python examples/04_drive_client.py                       # against the lane follower on the oval
    .venv/bin/python examples/04_drive_client.py --opponent fixed-lqng --laps 2

The "driver" is a pure-pursuit steering law on the track's centre line (the client loads the same built-in
track the server uses) with a speed target that drops in the bends. It answers every state message the server
sends after each tick, so it drives at 50 Hz; the server applies each input at the next tick.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path
from typing import Any

import httpx
import numpy as np
from websockets.sync.client import connect

from sim_core.track import Track
from sim_core.track_io import get_track

LOOKAHEAD = 7.0  # [m] along the centre line
STEER_GAIN = 1.6  # steer input per radian of heading error to the aim point
TOP_SPEED = 12.0  # [m/s] on straights
BEND_SPEED = 8.0  # [m/s] where the centre line ahead turns


def drive(track: Track, kart: dict[str, Any], lane_offset: float) -> tuple[float, float]:
    """Steer toward a point ``LOOKAHEAD`` m ahead on the kart's lane; throttle toward a speed for the road ahead."""
    position = np.array([kart["x"], kart["y"]])
    s, _d = track.project(position)
    point, tangent = track.point_at(s + LOOKAHEAD)
    aim = point + lane_offset * np.array([-tangent[1], tangent[0]])
    error = math.atan2(aim[1] - kart["y"], aim[0] - kart["x"]) - kart["heading"]
    error = (error + math.pi) % (2 * math.pi) - math.pi
    steer = max(-1.0, min(1.0, STEER_GAIN * error))
    _, far = track.point_at(s + 2 * LOOKAHEAD)
    bend = abs(math.atan2(tangent[0] * far[1] - tangent[1] * far[0], float(tangent @ far)))
    target = BEND_SPEED if bend > 0.3 else TOP_SPEED
    throttle = max(-1.0, min(1.0, 0.6 * (target - kart["speed"])))
    return steer, throttle


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--url", default="http://127.0.0.1:8000", help="the race server")
    parser.add_argument("--track", default="oval")
    parser.add_argument("--laps", type=int, default=1)
    parser.add_argument("--opponent", default="lane-follower", help="a controller from GET /api/controllers")
    args = parser.parse_args()

    body = {
        "track": args.track,
        "laps": args.laps,
        "karts": [{"controller": "human", "name": Path(__file__).name}, {"controller": args.opponent}],
    }
    response = httpx.post(f"{args.url}/api/races", json=body, timeout=30)
    if response.status_code != 201:
        raise SystemExit(f"could not start a race: {response.status_code} {response.text}")
    race = response.json()
    print(f"race {race['id']} on {race['track']}, {race['laps']} lap(s)")
    if race["viewer_url"]:
        print(f"watch it at {args.url}{race['viewer_url']}")

    track = get_track(args.track)
    lane_offset = 1.25  # lane 2, where kart 0 starts
    ws_url = (
        args.url.replace("http", "ws", 1) + f"/api/races/{race['id']}/drive?kart=0&token={race['drive_tokens']['0']}"
    )
    shown = 0.0
    with connect(ws_url, open_timeout=10) as ws:
        for raw in ws:
            message = json.loads(raw)
            if message["type"] == "state":
                kart = message["kart"]
                if message["status"] == "running":
                    steer, throttle = drive(track, kart, lane_offset)
                    ws.send(json.dumps({"steer": steer, "throttle": throttle, "seq": message["step"]}))
                if time.monotonic() - shown > 2.0:
                    shown = time.monotonic()
                    print(
                        f"t={message['time']:6.2f} s  lap {kart['lap']}  position {kart['position']}  "
                        f"speed {kart['speed']:5.2f} m/s  checkpoints {kart['checkpoints_passed']}"
                    )
            elif message["type"] == "error":
                print(f"server says: {message['error']}")
            elif message["type"] == "end":
                result = message["result"]
                print(f"race {message['status']} after {result['duration']:.2f} s")
                for k in sorted(result["karts"], key=lambda k: k["position"]):
                    time_text = f"{k['finish_time']:.2f} s" if k["finish_time"] is not None else "DNF"
                    print(
                        f"  {k['position']}. {k['name']:<20} {k['controller']:<14} {time_text:>9}  "
                        f"collisions at fault {k['collisions_at_fault']}, illegal lane changes "
                        f"{k['illegal_lane_changes']}, wall hits {k['wall_hits']}{'  WINNER' if k['winner'] else ''}"
                    )
                break


if __name__ == "__main__":
    main()
