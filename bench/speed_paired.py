"""CPU per simulated second of sorting and pick_place: this checkout against another one and
against the stock mink loop (bench/stock_mink_loop.py), paired and interleaved.

Two worker processes stay up for the whole run, one per checkout (this one, and `--base`: a
git commit or revision, extracted with `git archive` into a temporary directory, or a
directory holding a checkout). Each imports its own checkout's `orchestrator` and runs, per
request, one episode: the framework's sorting or pick_place on a seed, or the stock loop on
pick_place's plant on that seed, in that same process. The driver sends the same seed to both
workers in alternating order, one episode at a time, so that drift in the machine's load hits
both alike. Every figure is CPU time (`time.thread_time` of the episode, from building the
world to the result: robust to waiting for a shared core) per simulated second; the ratios
are medians of per-seed ratios:

* this / base: the change's effect, per scenario;
* framework / stock, in each worker's own process: what the framework costs over the
  yardstick (the stock loop is the same code in both workers, on each checkout's plant).

    python bench/speed_paired.py --base main --seeds 10
    python bench/speed_paired.py --base 252f585 --scenarios pick_place

The load average is printed at the start and the end: on a shared machine every figure grows
with it; the ratios much less.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
PACKAGES = {
    "orchestrator": "orchestrator",
    "orchestrator.machines": "machines",
    "orchestrator.robots": "robots",
    "orchestrator.scenarios": "scenarios",
    "orchestrator.skills": "skills",
}
"""The installed package's layout (pyproject.toml): package name -> directory of a checkout."""


def _use_checkout(root: Path) -> None:
    """Import `orchestrator` (and its mapped sub-packages) from the checkout at `root`, ahead
    of whatever is installed."""
    import importlib.util

    class Finder:
        @classmethod
        def find_spec(cls, name: str, path: object = None, target: object = None) -> object:
            if name not in PACKAGES:
                return None
            pkg = root / PACKAGES[name]
            return importlib.util.spec_from_file_location(
                name, pkg / "__init__.py", submodule_search_locations=[str(pkg)]
            )

    sys.meta_path.insert(0, Finder)  # type: ignore[arg-type]


def _worker(root: Path) -> None:
    """Serve episode requests (one JSON line each) on stdin, answer on stdout."""
    _use_checkout(root)
    import time

    sys.path.insert(0, str(HERE))
    from stock_mink_loop import stock_episode  # bench/stock_mink_loop.py

    import orchestrator
    from orchestrator.engine.runner import run_episode
    from orchestrator.language.load import load_scenario

    loaded = {name: load_scenario(name) for name in ("sorting", "pick_place")}
    for scenario in loaded.values():  # warm caches, as a batch worker would
        run_episode(scenario, 10_000)
    stock_episode(loaded["pick_place"].scenario, 10_000)
    print(json.dumps({"ready": orchestrator.__file__}), flush=True)
    for line in sys.stdin:
        req = json.loads(line)
        if req["kind"] == "stock":
            e = stock_episode(loaded["pick_place"].scenario, req["seed"])
            out = {"cpu": e.cpu_s, "sim": e.sim_s, "ok": e.ok}
        else:
            c0 = time.thread_time()
            result = run_episode(loaded[req["kind"]], req["seed"])
            cpu = time.thread_time() - c0
            out = {"cpu": cpu, "sim": result.sim_time, "ok": result.outcome == "succeeded"}
        print(json.dumps(out), flush=True)


def _checkout(ref: str) -> tuple[Path, str]:
    """A directory holding `ref` (a directory as is; a git revision extracted) and a label."""
    path = Path(ref)
    if path.is_dir():
        return path.resolve(), str(path)
    sha = subprocess.run(
        ["git", "-C", str(ROOT), "rev-parse", "--short", ref],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    out = Path(tempfile.gettempdir()) / f"speed_paired_{sha}"
    if not (out / "orchestrator").is_dir():
        tmp = Path(tempfile.mkdtemp(prefix=f"speed_paired_{sha}_"))
        archive = subprocess.run(
            ["git", "-C", str(ROOT), "archive", sha], capture_output=True, check=True
        ).stdout
        subprocess.run(["tar", "-x", "-C", str(tmp)], input=archive, check=True)
        native = "orchestrator/world/_native.c"
        same_c = (tmp / native).read_bytes() == (ROOT / native).read_bytes()
        built = sorted((ROOT / "orchestrator/world").glob("_native*.so"))
        if same_c and built:  # the compiled extension of the same source
            shutil.copy2(built[0], tmp / "orchestrator/world" / built[0].name)
        else:
            subprocess.run(
                [sys.executable, "setup.py", "build_ext", "--inplace"],
                cwd=tmp,
                capture_output=True,
                check=False,
            )
        tmp.rename(out)
    return out, f"{ref} ({sha})"


class Worker:
    def __init__(self, root: Path) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, str(Path(__file__).resolve()), "--worker", str(root)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
        )
        ready = json.loads(self._line())
        self.module = ready["ready"]

    def _line(self) -> str:
        assert self.proc.stdout is not None
        line = self.proc.stdout.readline()
        if not line:
            raise SystemExit(f"worker {self.proc.args} ended early (see its stderr above)")
        return line

    def run(self, kind: str, seed: int) -> dict:
        assert self.proc.stdin is not None
        self.proc.stdin.write(json.dumps({"kind": kind, "seed": seed}) + "\n")
        self.proc.stdin.flush()
        return json.loads(self._line())

    def close(self) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.close()
        self.proc.wait()


def _iqr(xs: list[float]) -> str:
    if len(xs) < 2:
        return "n/a"
    q = statistics.quantiles(xs, n=4)
    return f"{q[0]:.3f}-{q[2]:.3f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--base", default="main", help="git revision or checkout directory")
    parser.add_argument("--seeds", type=int, default=10)
    parser.add_argument("--seed-base", type=int, default=0)
    parser.add_argument("--scenarios", nargs="+", default=["sorting", "pick_place"])
    parser.add_argument("--worker", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker is not None:
        _worker(args.worker)
        return
    base_root, base_label = _checkout(args.base)
    load0 = os.getloadavg()[0]
    workers = {"this": Worker(ROOT), "base": Worker(base_root)}
    print(f"this: {workers['this'].module}\nbase: {base_label}: {workers['base'].module}")
    kinds = [*args.scenarios, "stock"]
    per: dict[tuple[str, str], list[dict]] = {(w, k): [] for w in workers for k in kinds}
    for i in range(args.seeds):
        seed = args.seed_base + i
        order = ["this", "base"] if i % 2 == 0 else ["base", "this"]
        for kind in kinds:
            for w in order:
                per[(w, kind)].append(workers[w].run(kind, seed))
        row = "  ".join(
            f"{k} {per[('this', k)][-1]['cpu'] / per[('this', k)][-1]['sim'] * 1e3:5.1f}"
            f"/{per[('base', k)][-1]['cpu'] / per[('base', k)][-1]['sim'] * 1e3:5.1f}"
            for k in kinds
        )
        print(f"seed {seed:3d} ms CPU per simulated s, this/base: {row}", flush=True)
    for w in workers.values():
        w.close()
    med = statistics.median

    def cps(e: dict) -> float:
        return e["cpu"] / e["sim"]

    print()
    for kind in kinds:
        this, base = per[("this", kind)], per[("base", kind)]
        ratios = [cps(a) / cps(b) for a, b in zip(this, base, strict=True)]
        ok_this, ok_base = sum(e["ok"] for e in this), sum(e["ok"] for e in base)
        print(
            f"{kind:11s} this {med(map(cps, this)) * 1e3:6.1f} ms/s (ok {ok_this}/{len(this)})"
            f"  base {med(map(cps, base)) * 1e3:6.1f} ms/s (ok {ok_base}/{len(base)})"
            f"  this/base median {med(ratios):.3f} (IQR {_iqr(ratios)})"
        )
    for kind in args.scenarios:
        for w in workers:
            ratios = [
                cps(a) / cps(b) for a, b in zip(per[(w, kind)], per[(w, "stock")], strict=True)
            ]
            print(
                f"{kind:11s} / stock loop, {w:4s} process: median {med(ratios):.3f} "
                f"(IQR {_iqr(ratios)})"
            )
    print(
        f"load average (1 min) {load0:.1f} at the start, {os.getloadavg()[0]:.1f} at the end "
        f"({os.cpu_count()} cores)"
    )


if __name__ == "__main__":
    main()
