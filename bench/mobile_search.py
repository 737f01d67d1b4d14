"""Figures of a mobile_search batch: success, how many blocks started out of view, metrics.

Reads the `results.jsonl` an `orchestrator batch mobile_search -n N --out DIR` wrote and
classifies every seed's start geometrically: the red block's centre inside the head camera's
field of view at t = 0 (in front of it, within both half-angles), and not hidden behind a
box of the room (a ray from the camera to it hits nothing else).

    orchestrator batch mobile_search -n 100 --workers 2 --out /tmp/ms100
    python bench/mobile_search.py /tmp/ms100/results.jsonl
"""

from __future__ import annotations

import argparse
import json
import math
import statistics

import mujoco
import numpy as np


def in_view_at_start(loaded, seed: int, camera: str = "head", obj: str = "cube") -> bool:
    """The object's centre is in the camera's image at t = 0 and nothing hides it."""
    from orchestrator.world import World

    world = World.build(loaded.scenario, seed)
    m, d = world.model, world.data
    cam = m.camera(camera).id
    spec = next(c for c in loaded.scenario.cameras if c.name == camera)
    pos, rot = d.cam_xpos[cam].copy(), d.cam_xmat[cam].reshape(3, 3)
    target = d.xpos[m.body(obj).id].copy()
    local = rot.T @ (target - pos)  # camera frame: looks along -z, image top +y
    if local[2] >= 0:
        return False
    half_v = math.radians(spec.fovy_deg) / 2
    half_h = math.atan(math.tan(half_v) * spec.width / spec.height)
    if (
        abs(math.atan2(local[0], -local[2])) > half_h
        or abs(math.atan2(local[1], -local[2])) > half_v
    ):
        return False
    geom = np.array([-1], dtype=np.int32)
    direction = (target - pos) / np.linalg.norm(target - pos)
    mujoco.mj_ray(m, d, pos, direction, None, 1, -1, geom)
    return int(geom[0]) == int(m.body(obj).geomadr[0])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("results", help="results.jsonl of the batch")
    args = parser.parse_args()
    from orchestrator.language.load import load_scenario

    loaded = load_scenario("mobile_search")
    rows = [json.loads(line) for line in open(args.results)]
    ok = [r for r in rows if r["outcome"] == "succeeded"]
    out = [r["seed"] for r in rows if not in_view_at_start(loaded, r["seed"])]
    ok_out = [r for r in ok if r["seed"] in out]
    print(
        f"succeeded {len(ok)}/{len(rows)}; block out of the first view: {len(out)}/{len(rows)}"
        f" seeds ({len(ok_out)} of them succeeded)"
    )
    for r in rows:
        if r["outcome"] != "succeeded":
            print(f"  seed {r['seed']}: {r['outcome']} in {r['final_state']}: {r['reason']}")
    collided = [
        r["seed"]
        for r in ok
        if any("collision" in str(e) for e in r.get("metrics", {}).get("events", []))
    ]
    print(f"successes that touched a wall, furniture or another block: {len(collided)}")
    for key in ("base_travel_m", "search_time_s", "cycle_time"):
        vals = [float(r["metrics"][key]) for r in ok if r["metrics"].get(key) is not None]
        if vals:
            q = statistics.quantiles(vals, n=100) if len(vals) > 1 else vals * 99
            print(f"{key}: p50 {statistics.median(vals):.2f}, p90 {q[89]:.2f}, max {max(vals):.2f}")
    looks = [
        sum(1 for t in r["transitions"] if t["trigger"] == "found" and t["from"].endswith("LOOK"))
        for r in ok
    ]
    print(f"confident detections per success: p50 {statistics.median(looks):g}, max {max(looks)}")
    rtf = [r["sim_time"] / r["wall_time"] for r in rows]
    print(f"wall-clock RTF in the batch: median {statistics.median(rtf):.1f}x")


if __name__ == "__main__":
    main()
