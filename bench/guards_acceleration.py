"""Each arm joint's largest acceleration over a run, against its datasheet limit, per physics step.

For each seed: the run's outcome and reason, and the largest |qacc| / limit (MuJoCo's `qacc`,
what the `joint_acceleration` guard reads) and |dqvel/dt| / limit (a finite difference over the
physics step) of any step outside the abort's controlled stop, by joint, with when and in which
state it happened; and how far the two readings ever are apart [rad/s^2].

    python bench/guards_acceleration.py SCENARIO SEED [SEED ...] [--set KEY=VALUE ...]
"""

from __future__ import annotations

import argparse

import numpy as np

from orchestrator.engine.runner import run_episode
from orchestrator.language.load import load_scenario


class Probe:
    """An observer of every physics step."""

    def on_start(self, ctx, executor) -> None:
        self.ex = executor
        self.dofs = np.asarray(ctx.world.arm_dof)
        self.lim = np.asarray(ctx.robot.acceleration_limits, float)
        self.prev = ctx.data.qvel[self.dofs].copy()
        self.worst_qacc = np.zeros(len(self.dofs))
        self.worst_fd = np.zeros(len(self.dofs))
        self.at = (0.0, "")
        self.apart = 0.0

    def on_step(self, ctx) -> None:
        qd = ctx.data.qvel[self.dofs]
        fd = np.abs(qd - self.prev) / ctx.dt_physics
        qa = np.abs(ctx.data.qacc[self.dofs])
        self.prev = qd.copy()
        self.apart = max(self.apart, float(np.max(np.abs(fd - qa))))
        stop = self.ex.stop
        if stop is not None and stop.active and not stop.gentle:
            return  # the abort's controlled stop: the guard's one exemption
        if np.max(qa / self.lim) > np.max(self.worst_qacc):
            self.at = (ctx.t, self.ex.leaf)
        self.worst_qacc = np.maximum(self.worst_qacc, qa / self.lim)
        self.worst_fd = np.maximum(self.worst_fd, fd / self.lim)

    def on_tick(self, ctx, executor) -> None:
        pass

    def on_end(self, *args) -> None:
        pass


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("scenario")
    parser.add_argument("seeds", type=int, nargs="+")
    parser.add_argument("--set", action="append", default=[], dest="overrides")
    args = parser.parse_args()
    loaded = load_scenario(args.scenario, args.overrides)
    for seed in args.seeds:
        p = Probe()
        r = run_episode(loaded, seed, [p])
        j = int(np.argmax(p.worst_qacc))
        print(
            f"{args.scenario} seed {seed}: {r.outcome} (reason {r.reason}); largest qacc/limit "
            f"{p.worst_qacc[j]:.2f} (joint {j + 1}, t={p.at[0]:.3f} s in {p.at[1]}), "
            f"finite difference {p.worst_fd.max():.2f}; the two at most {p.apart:.3f} rad/s^2 "
            f"apart",
            flush=True,
        )


if __name__ == "__main__":
    main()
