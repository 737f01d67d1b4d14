"""Contacts for the `collision` guard: MuJoCo contact sensors vs. the contact list.

The guard reads per-body contact sensors that MuJoCo fills during the step
(orchestrator/world/contacts.py). This bench runs one episode three ways, interleaved in
rounds (the same load), and times `mj_step` (thread CPU time) and the guard's read per step:

* `every pair`: a sensor for every robot-side element and scene body (as before issue 28:
  also the pairs the guard always allows, a finger with a free object),
* `forbidden pairs`: the world as built now (no sensor for an always-allowed pair),
* `contact list`: no contact sensor; after each step the contact list's geom pairs are
  looked up in a forbidden-pair table with numpy (what the guard would do instead).

The episodes must be identical (sensors do not act on the physics) and the contact list must
say "forbidden contact" at exactly the steps the sensors do; both are printed. A probe reads
the contacts from an observer, so its figure includes an observer call (~1 us) that the
guard's compiled check does not pay.

    python bench/contact_read.py [--scenario sorting pick_place] [--seed 1] [--rounds 3]

Timing is noisy on a shared machine; instructions are not. For those, run one variant per
process under callgrind (`--variant`, counting inside `mj_step` only) and the contact-list
lookup alone (`--lookups N`, the difference of two whole-process counts): docs/performance.md.
"""

from __future__ import annotations

import argparse
import statistics
import time

import mujoco
import numpy as np

VARIANTS = ("every pair", "forbidden pairs", "contact list")


def _patched_build(variant: str):
    """`add_contact_sensors` as `World.build` calls it, for one variant."""
    from orchestrator.world import contacts

    add = contacts.add_contact_sensors

    def every_pair(spec, root, fingers, tip, touchable, chassis=(), pushable=None):
        return add(spec, root, fingers, tip, set(), chassis, set())  # no pair left out

    def none(spec, *args, **kwargs):
        for s in add(spec, *args, **kwargs):
            spec.delete(spec.sensor(s.name))
        return []

    return {"every pair": every_pair, "forbidden pairs": add, "contact list": none}[variant]


def _forbidden_pairs(w) -> tuple[np.ndarray, np.ndarray]:
    """The guard's forbidden sensors as a geom-pair table, and their sensordata indices."""
    m = w.model
    touchable = set(w.objects) | ({w.phantom.name} if w.phantom is not None else set())
    objects = set(w.objects)
    table = np.zeros((m.ngeom, m.ngeom), dtype=bool)
    adrs = []
    for s in w.contact_sensors:
        allowed = (s.end_effector and s.partner in touchable) or (
            s.chassis and s.partner in objects
        )
        if allowed:
            continue
        adrs.append(s.adr)
        try:
            mine = [m.geom(s.robot).id]
        except KeyError:
            body = m.body(s.robot).id
            mine = [g for g in range(m.ngeom) if m.geom_bodyid[g] == body]
        if s.partner is None:
            other = list(range(m.ngeom))
        else:
            body = m.body(s.partner).id
            other = [g for g in range(m.ngeom) if m.geom_bodyid[g] == body]
        for a in mine:
            table[a, other] = True
            table[other, a] = True
    return table, np.array(adrs, dtype=int)


class _Probe:
    """An observer whose `on_step` reads the contacts one way, timing only that read."""

    def __init__(self, read) -> None:
        self.read = read
        self.said: list[bool] = []
        self.ns = 0

    def on_start(self, ctx, executor) -> None:
        pass

    def on_tick(self, ctx, executor) -> None:
        pass

    def on_end(self, ctx, executor, result) -> None:
        pass

    def on_step(self, ctx) -> None:
        t0 = time.thread_time_ns()
        said = self.read(ctx.data)
        self.ns += time.thread_time_ns() - t0
        self.said.append(said)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", nargs="+", default=["sorting", "pick_place"])
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument(
        "--variant",
        choices=VARIANTS,
        help="run one episode of this variant only and print its outcome (for an instruction "
        "count: valgrind --tool=callgrind --toggle-collect=mj_step python bench/contact_read.py "
        "--variant ...)",
    )
    parser.add_argument("--set", nargs="*", default=[], help="scenario overrides, as `run --set`")
    parser.add_argument(
        "--lookups",
        type=int,
        help="step the scene (sleeping off, so resting objects keep their contacts) 200 "
        "times, then look the contact list up in the forbidden-pair table this many times "
        "(for an instruction count: the difference of two counts, e.g. 5000 and 0, divided by "
        "5000 is one lookup)",
    )
    args = parser.parse_args()

    import os

    if args.lookups is not None:
        _lookups(args.scenario[0], args.seed, args.lookups)
        return

    if args.variant is not None:
        from orchestrator.engine.runner import run_episode
        from orchestrator.language.load import load_scenario
        from orchestrator.world import world as world_module

        for name in args.scenario:
            loaded = load_scenario(name, args.set or None)
            world_module.add_contact_sensors = _patched_build(args.variant)
            r = run_episode(loaded, args.seed)
            print(f"{name} seed {args.seed} {args.variant}: {r.outcome} at {r.sim_time:.3f} s")
        return
    print(f"load {os.getloadavg()[0]:.2f} (1-minute average)")
    for name in args.scenario:
        _measure(name, args.seed, args.rounds, args.set)


def _lookups(name: str, seed: int, n: int) -> None:
    """`n` contact-list lookups on `name`'s scene after 200 steps (see `--lookups`)."""
    from orchestrator.language.load import load_scenario
    from orchestrator.world import world as world_module

    world_module.add_contact_sensors = _patched_build("every pair")
    w = world_module.World.build(load_scenario(name).scenario, seed)
    table, _ = _forbidden_pairs(w)
    w.model.opt.enableflags &= ~int(mujoco.mjtEnableBit.mjENBL_SLEEP)
    d = w.data
    for _ in range(200):
        mujoco.mj_step(w.model, d)
    for _ in range(n):
        if d.ncon:
            g = d.contact.geom
            bool(table[g[:, 0], g[:, 1]].any())
    print(f"{name}: {d.ncon} contacts in the list, {n} lookups")


def _measure(name: str, seed: int, rounds: int, overrides: list[str]) -> None:
    """Run `name`'s episode `seed` in every variant, `rounds` times, and print the table."""
    from orchestrator.engine import step as step_module
    from orchestrator.engine.runner import run_episode
    from orchestrator.language.load import load_scenario
    from orchestrator.world import world as world_module

    real_step = mujoco.mj_step
    spent = [0, 0]  # ns in mj_step, calls

    def timed_step(m, d):
        t0 = time.thread_time_ns()
        real_step(m, d)
        spent[0] += time.thread_time_ns() - t0
        spent[1] += 1

    add = world_module.add_contact_sensors
    loaded = load_scenario(name, overrides or None)
    variants = VARIANTS
    world_module.add_contact_sensors = _patched_build("every pair")
    try:
        every = world_module.World.build(loaded.scenario, seed)
    finally:
        world_module.add_contact_sensors = add
    w = world_module.World.build(loaded.scenario, seed)  # as built: the forbidden pairs
    table, adrs = _forbidden_pairs(w)
    lo, hi = int(adrs.min()), int(adrs.max()) + 1
    assert hi - lo == len(adrs), "the forbidden sensors form one block"

    def by_sensors(d):  # as the guard reads them: one contiguous block
        return any(d.sensordata[lo:hi].tolist())

    def by_list(d):
        if not d.ncon:
            return False
        g = d.contact.geom
        return bool(table[g[:, 0], g[:, 1]].any())

    reads = {"every pair": None, "forbidden pairs": by_sensors, "contact list": by_list}
    us: dict[str, list[float]] = {k: [] for k in variants}
    read_us: dict[str, list[float]] = {k: [] for k in variants}
    said: dict[str, list[bool]] = {}
    results = {}
    for k in range(rounds + 1):  # round 0 warms the caches up, not counted
        for label in variants:
            world_module.add_contact_sensors = _patched_build(label)
            step_module.mujoco = _Shim(timed_step)
            read = reads[label]
            probe = _Probe(read) if read is not None else None
            spent[:] = [0, 0]
            try:
                r = run_episode(loaded, seed, observers=[probe] if probe else [])
            finally:
                world_module.add_contact_sensors = add
                step_module.mujoco = mujoco
            results[label] = (str(r.outcome), r.sim_time, spent[1], str(r.metrics))
            if k == 0:
                continue
            us[label].append(spent[0] / spent[1] / 1e3)
            if probe is not None:
                read_us[label].append(probe.ns / spent[1] / 1e3)
                said[label] = probe.said
    runs = set(results.values())
    print(
        f"{name} seed {seed}: {len(every.contact_sensors)} contact sensors for every pair, "
        f"{len(adrs)} for the forbidden pairs; "
        + " / ".join(f"{o} {t:.3f} s" for o, t, _, _ in runs)
        + f" ({'identical' if len(runs) == 1 else 'DIFFERENT'} episodes)"
    )
    a, b = np.array(said["forbidden pairs"]), np.array(said["contact list"])
    print(
        f"  steps with a forbidden contact: sensors {int(a.sum())}, contact list "
        f"{int(b.sum())}, agree at {int((a == b).sum())}/{len(a)}"
    )
    base = statistics.median(us["every pair"])
    clock = _clock_us()
    print(f"  (the probe's clock and call cost {clock:.2f} us a read, taken off its figures)")
    for label in variants:
        step_us = statistics.median(us[label])
        read = statistics.median(read_us[label]) - clock if read_us[label] else 0.0
        print(
            f"  {label:15s} mj_step {step_us:6.2f} us ({step_us / base:.3f}x)"
            f"  + read {read:5.2f} us = {step_us + read:6.2f} us/step"
        )


def _clock_us(n: int = 20_000) -> float:
    """What `_Probe` adds to a read that does nothing [us]: two clock reads and a call."""
    probe = _Probe(lambda d: False)
    for _ in range(n):
        probe.on_step(_NoCtx)
    return probe.ns / n / 1e3


class _NoCtx:
    data = None


class _Shim:
    """`mujoco` as the step loop sees it, with `mj_step` timed."""

    def __init__(self, timed) -> None:
        self.mj_step = timed

    def __getattr__(self, name):
        return getattr(mujoco, name)


if __name__ == "__main__":
    main()
