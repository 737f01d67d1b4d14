"""Instructions the IK costs, counted by valgrind: a figure the machine's load cannot move.

CPU times on a shared 2-core host move by ±15 % between two runs of the same code; the
instructions a piece of code executes do not. This runs a child process under `valgrind
--tool=callgrind`, which zeroes its counts where the measured work starts and writes them
out where it ends (the child calls `zlib.crc32` and `zlib.adler32` there, functions nothing
else in the work calls: `--zero-before`, `--dump-before`), and reports them:

* `--ik N`: N steps of `IKSolver.reference_step` of the Panda along a fixed motion (a 40 cm
  line there and back with a 60 deg turn of the hand, 10 ms steps, after 20 warm-up steps):
  instructions per step;
* `--scenario NAME --seed S`: one episode (after a warm-up episode of another seed, as a
  batch worker runs them): instructions per physics step.

Instructions are not time (a cache miss costs more than an add), but two checkouts running
the same work compare to ~0.1 %: run this in each and compare the counts. Needs valgrind
(`apt-get install valgrind`); valgrind runs the code ~50x slower (an `--ik 1000` count takes
a few minutes, a sorting episode's tens of minutes).

    python bench/ik_instructions.py --ik 1000
    python bench/ik_instructions.py --scenario sorting --seed 1
"""

from __future__ import annotations

import argparse
import os
import re
import subprocess
import sys
import tempfile


def _child(args: argparse.Namespace) -> None:
    """The set-up, then the measured work between the two markers: prints how many units
    it ran."""
    import gc
    import zlib

    def start() -> None:
        # the set-up's objects out of the collector's reach: a full collection over the
        # imported heap (~5e7 instructions) would otherwise land in the work at random
        gc.collect()
        gc.freeze()
        zlib.crc32(b"")  # callgrind: zero the counts

    if args.ik:
        import mink
        import numpy as np
        from orchestrator.robots import get_robot
        from orchestrator.skills.ik import IKSolver
        from orchestrator.skills.targets import rot_down

        from orchestrator.world.world import robot_only_model

        robot = get_robot("panda")
        ik = IKSolver(robot, robot_only_model(robot), 0.01, np.zeros(3))
        ik.reset(np.array(robot.home))
        p0, _ = ik.tcp_pose()
        targets = []
        for i in range(args.ik):
            s = 0.5 - 0.5 * np.cos(2 * np.pi * i / args.ik)
            rot = mink.SO3.from_matrix(rot_down(np.pi / 3 * s))
            targets.append((p0 + np.array([0.0, 0.4 * s, -0.1 * s]), rot))
        for pos, rot in targets[:20]:
            ik.reference_step(pos, rot, 0.01)
        ik.reset(np.array(robot.home))
        start()
        for pos, rot in targets:
            ik.reference_step(pos, rot, 0.01)
        zlib.adler32(b"")  # callgrind: write them out
        print(f"units {len(targets)}")
        return
    from orchestrator.engine.runner import run_episode
    from orchestrator.language.load import load_scenario

    loaded = load_scenario(args.scenario)
    dt = loaded.scenario.physics.timestep_s
    run_episode(loaded, 10_000)  # warm the caches, as a batch worker would
    start()
    result = run_episode(loaded, args.seed)
    zlib.adler32(b"")
    print(f"units {round(result.sim_time / dt)}")


def _count() -> tuple[int, int]:
    """(units, instructions) of the child's measured work under callgrind."""
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "callgrind.out")
        run = subprocess.run(
            [
                "valgrind",
                "--tool=callgrind",
                "--zero-before=zlib_crc32",
                "--dump-before=zlib_adler32",
                f"--callgrind-out-file={out}",
                sys.executable,
                __file__,
                "--child",
                *sys.argv[1:],
            ],
            capture_output=True,
            text=True,
            check=False,  # a failure is reported below, with valgrind's output
        )
        units = re.search(r"^units (\d+)$", run.stdout, re.MULTILINE)
        if run.returncode != 0 or units is None or not os.path.exists(out + ".1"):
            raise SystemExit(f"valgrind run failed:\n{run.stdout}\n{run.stderr[-2000:]}")
        with open(out + ".1") as f:  # the dump at the end marker
            total = re.search(r"^(?:summary|totals): (\d+)", f.read(), re.MULTILINE)
        if total is None:
            raise SystemExit(f"no instruction total in {out}.1")
    return int(units.group(1)), int(total.group(1))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ik", type=int, default=0, help="reference_step calls to count")
    parser.add_argument("--scenario", default="sorting")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        _child(args)
        return
    n, instructions = _count()
    what = "reference_step" if args.ik else f"physics step ({args.scenario} seed {args.seed})"
    print(f"{instructions:,} instructions over {n} units: {instructions / n:,.0f} per {what}")


if __name__ == "__main__":
    main()
