"""Perception accuracy and cost: colour detection against the simulator's truth, per renderer.

Accuracy: `--seeds` randomized scenes (3-6 cubes of red/green/blue/yellow at random poses
under pick_place_vision's overhead camera, some partly out of view; light intensity and
direction, colour jitter, pixel and depth noise drawn per seed). For every cube fully in
view: class accuracy (a detection of its class, confidence >= 0.5, matched to it), position
error of its top-face centre (median, p95, max) and yaw error (median, max, modulo the
square's quarter turn).
Over every detection: wrong classes reported with confidence >= 0.5 (must be none).

Cost: one `detect` at 320x240 (render + segmentation-free detection), median over the scenes,
per renderer, as wall time and as the CPU time of the process (all its threads: OpenGL's
llvmpipe and OpenCV render and label on several; CPU time does not count time another
process held the cores, so it is the figure to read on a shared machine); and the wall time of a
pick_place_vision episode over a pick_place one (median of ABBA pairs on the same seeds).

    python bench/perception.py [--seeds 200] [--pairs 6] [--backends opengl raycast]
"""

from __future__ import annotations

import argparse
import statistics
import time

import mujoco
import numpy as np
from rich.progress import Progress

from orchestrator.engine.runner import run_episode
from orchestrator.language.load import load_scenario
from orchestrator.perception.backends import backend_status
from orchestrator.perception.detections import detect_objects
from orchestrator.perception.rig import CameraRig
from orchestrator.perception.truth import fully_in_view, match_detections, true_objects
from orchestrator.world.world import World

COLOURS = {
    "red": [0.85, 0.15, 0.15, 1.0],
    "green": [0.2, 0.7, 0.25, 1.0],
    "blue": [0.15, 0.3, 0.85, 1.0],
    "yellow": [0.9, 0.8, 0.15, 1.0],
}
RANDOMIZE = {
    "light_intensity": [0.6, 1.3],
    "light_tilt_deg": 35,
    "colour_jitter": 0.03,
    "pixel_noise": 4.0,
    "depth_noise_m": 0.0005,
}
REGION = ((0.29, 0.71), (-0.42, 0.16))
"""Where cube centres are drawn (x, y) [m]: the camera sees x 0.27-0.73, y -0.43-0.17."""


def scene(base, seed: int, backend: str):
    """pick_place_vision's camera over 3-6 random cubes (no two closer than 7.5 cm)."""
    rng = np.random.default_rng([seed, 0xBE4C])
    n = int(rng.integers(3, 7))
    xy: list[np.ndarray] = []
    while len(xy) < n:
        p = np.array([rng.uniform(*REGION[0]), rng.uniform(*REGION[1])])
        if all(np.linalg.norm(p - q) >= 0.075 for q in xy):
            xy.append(p)
    objects = []
    for i, p in enumerate(xy):
        colour = str(rng.choice(list(COLOURS)))
        objects.append(
            {
                "name": f"cube{i}",
                "size": [0.05, 0.05, 0.05],
                "xy": p.tolist(),
                "yaw_deg": float(rng.uniform(-45, 45)),
                "rgba": COLOURS[colour],
            }
        )
    raw = base.model_dump()
    raw["scene"]["objects"] = objects
    raw["perception"]["randomize"] = RANDOMIZE
    raw["perception"]["backend"] = backend
    return type(base).model_validate(raw)


def accuracy(base, seeds: int, backend: str, progress: Progress) -> dict:
    pos, yaw, render_ms, detect_ms, cpu_ms = [], [], [], [], []
    in_view = correct = wrong_confident = detections = 0
    task = progress.add_task(f"{backend} scenes", total=seeds)
    for seed in range(seeds):
        scn = scene(base, seed, backend)
        world = World.build(scn, seed)
        mujoco.mj_forward(world.model, world.data)
        rig = CameraRig(world.model, scn, seed)
        rig.capture(world.data, "overhead")  # opens the renderer: not part of a detect
        t0, c0 = time.perf_counter(), time.process_time()
        frame = rig.capture(world.data, "overhead")
        t1 = time.perf_counter()
        found = detect_objects(
            frame, scn.perception.class_boxes(), 30, None, RANDOMIZE["depth_noise_m"]
        )
        t2, c2 = time.perf_counter(), time.process_time()
        rig.close()
        render_ms.append((t1 - t0) * 1e3)
        detect_ms.append((t2 - t1) * 1e3)
        cpu_ms.append((c2 - c0) * 1e3)
        truths = true_objects(world)
        matches = match_detections(found, truths)
        detections += len(found)
        wrong = [m for m in matches if not m.correct and m.detection.confidence >= 0.5]
        wrong_confident += len(wrong)
        for truth in truths:
            if not fully_in_view(truth, frame):
                continue
            in_view += 1
            mine = [
                m
                for m in matches
                if m.truth is truth and m.correct and m.detection.confidence >= 0.5
            ]
            if mine:
                correct += 1
                best = min(mine, key=lambda m: m.position_error_m)
                pos.append(best.position_error_m * 1e3)
                yaw.append(best.yaw_error_deg)
        progress.advance(task)
    return {
        "in_view": in_view,
        "correct": correct,
        "detections": detections,
        "wrong_confident": wrong_confident,
        "pos": np.array(pos),
        "yaw": np.array(yaw),
        "render_ms": float(np.median(render_ms)),
        "detect_ms": float(np.median(detect_ms)),
        "cpu_ms": float(np.median(cpu_ms)),
    }


def episode_ratio(pairs: int) -> tuple[float, float, float, int]:
    """Median and IQR of wall(pick_place_vision) / wall(pick_place), ABBA pairs; successes."""
    vision, plain = load_scenario("pick_place_vision"), load_scenario("pick_place")
    run_episode(vision, 10_000)  # warm caches (and the renderer probe) as a worker would
    run_episode(plain, 10_000)
    ratios, ok = [], 0
    for i in range(pairs):
        order = (vision, plain) if i % 2 == 0 else (plain, vision)
        walls = {}
        for loaded in order:
            t0 = time.perf_counter()
            result = run_episode(loaded, i)
            walls[loaded.name] = time.perf_counter() - t0
            ok += loaded is vision and result.outcome == "succeeded"
        ratios.append(walls["pick_place_vision"] / walls["pick_place"])
    if len(ratios) < 2:
        return ratios[0], ratios[0], ratios[0], ok
    q1, med, q3 = statistics.quantiles(ratios, n=4)
    return med, q1, q3, ok


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=200, help="Randomized scenes.")
    parser.add_argument("--pairs", type=int, default=6, help="Episode pairs for the ratio.")
    parser.add_argument("--backends", nargs="+", default=["opengl", "raycast"])
    args = parser.parse_args()
    status = backend_status()
    backends = [b for b in args.backends if b != "opengl" or status.opengl]
    print(f"camera renderer here: {status.describe()}")
    base = load_scenario("pick_place_vision").scenario
    with Progress(transient=True) as progress:
        results = {b: accuracy(base, args.seeds, b, progress) for b in backends if args.seeds}
    for backend, r in results.items():
        pos, yaw = r["pos"], r["yaw"]
        print(
            f"{backend}: {args.seeds} scenes, {r['in_view']} cubes fully in view, "
            f"{r['detections']} detections\n"
            f"  class accuracy {r['correct'] / r['in_view'] * 100:.2f} % "
            f"({r['correct']}/{r['in_view']}); wrong class with confidence >= 0.5: "
            f"{r['wrong_confident']}\n"
            f"  position error median {np.median(pos):.2f} mm, p95 "
            f"{np.percentile(pos, 95):.2f} mm, max {pos.max():.2f} mm\n"
            f"  yaw error median {np.median(yaw):.2f} deg, max {yaw.max():.2f} deg\n"
            f"  one detect at 320x240: render {r['render_ms']:.1f} ms + detection "
            f"{r['detect_ms']:.1f} ms = {r['render_ms'] + r['detect_ms']:.1f} ms wall (median); "
            f"CPU time of the process {r['cpu_ms']:.1f} ms"
        )
    if args.pairs:
        med, q1, q3, ok = episode_ratio(args.pairs)
        print(
            f"pick_place_vision / pick_place wall time = {med:.3f} (IQR {q1:.3f}-{q3:.3f}, "
            f"{args.pairs} pairs; vision succeeded {ok}/{args.pairs}; renderer "
            f"{status.chosen})"
        )


if __name__ == "__main__":
    main()
