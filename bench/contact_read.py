"""Contacts for the `collision` guard: MuJoCo contact sensors vs. the contact list.

The guard reads per-body contact sensors that MuJoCo fills during the step
(orchestrator/world/contacts.py). The alternative is to read MuJoCo's contact list after the
step and classify each contact's geom pair with a lookup table (numpy). This bench records
one episode's physics states (every step), then replays the same steps back to back on

* `sensors`: the world as built (every contact sensor, as the guard reads them),
* `forbidden only`: the world without the sensors of pairs that are always allowed (a
  finger or a tool with a free object or the phantom: the guard never fires on those),
* `contact list`: the world without any contact sensor, plus the lookup of every contact of
  the step in a forbidden-pair table (what the guard would do instead),

and reports the median CPU time of a step of each (interleaved rounds: same load), and
whether the contact list said "forbidden contact" at exactly the steps the sensors did.

    python bench/contact_read.py [--scenario sorting pick_place] [--seed 1] [--rounds 5]
"""

from __future__ import annotations

import argparse
import statistics
import time

import mujoco
import numpy as np




def _patched_build(keep):
    """`World.build` adding only the contact sensors `keep(sensor)` accepts."""
    from orchestrator.world import contacts

    add = contacts.add_contact_sensors

    def filtered(spec, *args, **kwargs):
        kept = []
        for s in add(spec, *args, **kwargs):
            if keep(s):
                kept.append(s)
            else:
                spec.delete(spec.sensor(s.name))
        return kept

    return filtered


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
        t0 = time.perf_counter_ns()
        said = self.read(ctx.data)
        self.ns += time.perf_counter_ns() - t0
        self.said.append(said)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenario", nargs="+", default=["sorting", "pick_place"])
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()

    import os

    from orchestrator.engine import step as step_module
    from orchestrator.engine.runner import run_episode
    from orchestrator.language.load import load_scenario
    from orchestrator.world import world as world_module

    real_step = mujoco.mj_step
    spent = [0, 0]  # ns in mj_step, calls

    def timed_step(m, d):
        t0 = time.perf_counter_ns()
        real_step(m, d)
        spent[0] += time.perf_counter_ns() - t0
        spent[1] += 1

    add = world_module.add_contact_sensors
    print(f"load {os.getloadavg()[0]:.2f} (1-minute average)")
    for name in args.scenario:
        loaded = load_scenario(name)
        touchable = set()
        for o in loaded.scenario.scene.objects:
            touchable.add(o.name)
        if loaded.scenario.scene.phantom is not None:
            touchable.add(loaded.scenario.scene.phantom.name)
        variants = {
            "sensors": lambda s: True,
            "forbidden only": lambda s: not (s.end_effector and s.partner in touchable),
            "contact list": lambda s: False,
        }
        w = world_module.World.build(loaded.scenario, args.seed)
        table, adrs = _forbidden_pairs(w)
        n_sensors, n_forbidden = len(w.contact_sensors), len(adrs)

        lo, hi = int(adrs.min()), int(adrs.max()) + 1
        assert hi - lo == len(adrs), "the world puts the forbidden sensors in one block"

        def by_sensors(d):  # as the guard reads them: one contiguous block
            return any(d.sensordata[lo:hi].tolist())

        def by_list(d):
            if not d.ncon:
                return False
            g = d.contact.geom
            return bool(table[g[:, 0], g[:, 1]].any())

        reads = {"sensors": by_sensors, "forbidden only": None, "contact list": by_list}
        us: dict[str, list[float]] = {k: [] for k in variants}
        read_us: dict[str, list[float]] = {k: [] for k in variants}
        said: dict[str, list[bool]] = {}
        results = {}
        for k in range(args.rounds + 1):  # round 0 warms the caches up, not counted
            for label, keep in variants.items():
                world_module.add_contact_sensors = _patched_build(keep)
                step_module.mujoco = _Shim(timed_step)
                probe = _Probe(reads[label]) if reads[label] else None
                spent[:] = [0, 0]
                try:
                    r = run_episode(loaded, args.seed, observers=[probe] if probe else [])
                finally:
                    world_module.add_contact_sensors = add
                    step_module.mujoco = mujoco
                if k == 0:
                    continue
                us[label].append(spent[0] / spent[1] / 1e3)
                if probe is not None:
                    read_us[label].append(probe.ns / spent[1] / 1e3)
                    said[label] = probe.said
                results[label] = (str(r.outcome), r.sim_time, spent[1], str(r.metrics))
        print(
            f"{name} seed {args.seed}: {n_sensors} contact sensors ({n_forbidden} forbidden); "
            f"{' / '.join(f'{o} {t:.3f} s' for o, t, _, _ in set(results.values()))} "
            f"({'identical' if len(set(results.values())) == 1 else 'DIFFER'} in every variant)"
        )
        a, b = np.array(said["sensors"]), np.array(said["contact list"])
        print(
            f"  steps with a forbidden contact: sensors {int(a.sum())}, contact list "
            f"{int(b.sum())}, agree at {int((a == b).sum())}/{len(a)}"
        )
        base = statistics.median(us["sensors"])
        for label in variants:
            step_us = statistics.median(us[label])
            read = statistics.median(read_us[label]) if read_us[label] else 0.0
            print(
                f"  {label:15s} mj_step {step_us:6.2f} us ({step_us / base:.3f}x)"
                f"  + guard read {read:5.2f} us = {step_us + read:6.2f} us/step"
            )


class _Shim:
    """`mujoco` as the step loop sees it, with `mj_step` timed."""

    def __init__(self, timed) -> None:
        self.mj_step = timed

    def __getattr__(self, name):
        return getattr(mujoco, name)


if __name__ == "__main__":
    main()
