"""Regenerate the pictures in docs/images/: Rerun's view of every bundled scenario's recording,
of live runs, and the bundled machines drawn by Graphviz. Everything renders headless.

    python docs/make_images.py                 # every picture in SCENES
    python docs/make_images.py rerun_surgical  # some of them, by name
    python docs/make_images.py --list          # what there is, and what each needs

A new picture is one more entry in `SCENES` (a `ViewerShot` for a recorded episode, a
`LiveShot` or `SpawnShot` for live streaming, a `MachineDrawing` for a machine).

Regeneration is deterministic: a `ViewerShot` records the episode up to `at_s` simulated
seconds only, so the viewer's time cursor (which follows a recording to its end) stands at
exactly `at_s`; a `SpawnShot` sets the native viewer's cursor through `rerun viewer-mcp`.
A picture that cannot be made (a tool missing, a viewer that does not come up in time) is
reported and the others are made; the exit code is 1 if any failed.

What it needs is not a dependency of the package, and CI does not run it:

* Rerun's web viewer in headless Chromium: `apt-get install -y chromium chromium-driver`
  and `pip install -e '.[images]'` (Selenium, Pillow). Nothing downloads a browser.
* Graphviz for the machines: `apt-get install -y graphviz`.
* `SpawnShot` only: an X server without a screen and a software Vulkan driver for Rerun's
  native viewer: `apt-get install -y xvfb mesa-vulkan-drivers`.

Every viewer and browser it starts listens on 127.0.0.1 only and is stopped before it exits.
"""

from __future__ import annotations

import argparse
import contextlib
import hashlib
import io
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

IMAGES = Path(__file__).resolve().parent / "images"
WINDOW = (1600, 900)
"""Browser viewport and native window size [px]."""
SMALL_WINDOW = (1280, 720)
"""The smaller browser viewport every recorded scenario is also shown in (`NAME_1280x720.png`):
the default layout is made for both (orchestrator/recording/blueprint.py `WINDOWS`)."""
CHROMIUM = "/usr/bin/chromium"
CHROMEDRIVER = "/usr/bin/chromedriver"
CHROMIUM_FLAGS = (
    "--headless=new", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
)  # fmt: skip
APT = "apt-get install -y"


# -- what to render -------------------------------------------------------------------------
@dataclass(frozen=True)
class ViewerShot:
    """A recorded episode (`.rrd`) opened in Rerun's web viewer in headless Chromium.

    Attributes:
        name: File name in docs/images/ (without `.png`).
        scenario: Bundled scenario name or path.
        seed: Episode seed.
        at_s: The moment shown [s of simulated time]: the episode is recorded up to it (the
            run itself goes on to its end), so the time cursor stands exactly there. None:
            the end of the episode.
    """

    name: str
    scenario: str
    seed: int = 0
    at_s: float | None = None
    needs = ("chromium", "chromedriver", "selenium", "pillow", "rerun")

    def render(self, work: Path) -> Path:
        rrd = work / f"{self.name}.rrd"
        _record(self.scenario, self.seed, until_s=self.at_s, path=rrd)
        with _web_viewer(work, rrd) as (page, _), _browser() as browser:
            started = time.monotonic()
            browser.get(page)
            out = _capture(browser, self.name)
            print(
                f"  {rrd.stat().st_size / 1e6:.2f} MB, shown in {time.monotonic() - started:.0f} s"
            )
            _viewport(browser, SMALL_WINDOW)
            w, h = SMALL_WINDOW
            _capture(browser, f"{self.name}_{w}x{h}")
            return out


@dataclass(frozen=True)
class LiveShot:
    """An episode streamed live (`orchestrator run --connect`) to `rerun --serve-web`, watched
    in its web viewer while it runs.

    Attributes:
        name: File name in docs/images/ (without `.png`).
        scenario: Bundled scenario name or path.
        seed: Episode seed.

    The viewer follows the run live: the picture shows its end.
    """

    name: str
    scenario: str
    seed: int = 0
    needs = ("chromium", "chromedriver", "selenium", "pillow", "rerun")

    def render(self, work: Path) -> Path:
        with _web_viewer(work, None) as (page, grpc), _browser() as browser:
            browser.get(page)
            time.sleep(3.0)  # the page is open and connected before the run starts
            _record(self.scenario, self.seed, connect=grpc)
            return _capture(browser, self.name, timeout_s=480.0)


@dataclass(frozen=True)
class SpawnShot:
    """An episode streamed live (`orchestrator run --spawn`) to Rerun's native viewer, run
    under Xvfb and captured through the viewer's own `rerun viewer-mcp` screenshot tool.

    Attributes:
        name: File name in docs/images/ (without `.png`).
        scenario: Bundled scenario name or path.
        seed: Episode seed.
        at: Where to put the time cursor, as a fraction of the episode (None: the end).
    """

    name: str
    scenario: str
    seed: int = 0
    at: float | None = None
    needs = ("xvfb", "vulkan", "rerun")

    def render(self, work: Path) -> Path:
        out = IMAGES / f"{self.name}.png"
        with _native_viewer(work) as port:
            result = _record(self.scenario, self.seed, spawn=True, port=port)
            time.sleep(3.0)
            calls = []
            if self.at is not None:
                t_ns = round(self.at * result.sim_time * 1e9)
                cursor = {"time": {"time": t_ns}, "play_state": "PLAY_STATE_PAUSED"}
                calls.append(("rerun_set_time_cursor", cursor))
            calls.append(("rerun_save_screenshot", {"file_path": str(out), "max_size": 0}))
            _mcp(port, calls)
        return out


@dataclass(frozen=True)
class MachineDrawing:
    """A bundled machine drawn by Graphviz (`orchestrator graph MACHINE --format dot`).

    Attributes:
        name: File name in docs/images/ (without `.png`).
        machine: Bundled machine name or path.
    """

    name: str
    machine: str
    needs = ("dot",)

    def render(self, work: Path) -> Path:
        from orchestrator.language.graph import to_dot
        from orchestrator.language.load import load_machine

        out = IMAGES / f"{self.name}.png"
        source = to_dot(load_machine(self.machine))
        subprocess.run(
            ["dot", "-Tpng", "-Gdpi=96", "-o", str(out)], input=source.encode(), check=True
        )
        # what the drawing was made from: tests/test_doc_images.py fails once the machine changes
        digest_file(self.name).write_text(dot_digest(source) + "\n")
        return out


def dot_digest(source: str) -> str:
    """The SHA-256 of a machine's DOT source (`orchestrator graph M --format dot`)."""
    return hashlib.sha256(source.encode()).hexdigest()


def digest_file(name: str) -> Path:
    """Where the DOT source's digest of drawing `name` is kept, beside its PNG."""
    return IMAGES / f"{name}.dot.sha256"


Scene = ViewerShot | LiveShot | SpawnShot | MachineDrawing

SCENES: list[Scene] = [
    ViewerShot("rerun_pick_place", "pick_place", at_s=1.2),
    ViewerShot("rerun_pick_place_vision", "pick_place_vision", at_s=1.3),
    ViewerShot("rerun_mobile_search", "mobile_search", at_s=5.0),
    ViewerShot("rerun_sorting", "sorting", at_s=12.0),
    ViewerShot("rerun_sorting_conveyor", "sorting_conveyor", at_s=15.0),
    ViewerShot("rerun_surgical", "surgical", at_s=33.4),
    ViewerShot("rerun_surgical_complication", "surgical_complication", at_s=36.0),
    ViewerShot("rerun_stack", "stack", at_s=2.3),
    ViewerShot("rerun_reach_random", "reach_random", at_s=0.6),
    ViewerShot("rerun_pick_place_ur5", "pick_place_ur5", at_s=1.2),
    ViewerShot("rerun_pick_place_so101", "pick_place_so101", at_s=1.2),
    ViewerShot("rerun_sorting_ur5", "sorting_ur5", at_s=12.0),
    MachineDrawing("machine_pick_place", "pick_place"),
    MachineDrawing("machine_surgical", "surgical"),
    LiveShot("live_connect_pick_place", "pick_place"),
    SpawnShot("live_spawn_pick_place", "pick_place", at=0.36),
]
"""Every picture, in the order they are made: every bundled scenario in the web viewer at a
moment that shows its flow (`orchestrator list`), the machines, the live paths."""


# -- the tools ------------------------------------------------------------------------------
def _rerun() -> str | None:
    """Rerun's executable: the one the rerun-sdk wheel ships, else `rerun` on PATH."""
    with contextlib.suppress(ImportError):
        import rerun_cli

        exe = Path(rerun_cli.__file__).parent / "rerun"
        if exe.is_file():
            return str(exe)
    return shutil.which("rerun")


def _importable(module: str) -> bool:
    try:
        __import__(module)
    except ImportError:
        return False
    return True


TOOLS = {
    "chromium": (lambda: Path(CHROMIUM).is_file(), f"{APT} chromium"),
    "chromedriver": (lambda: Path(CHROMEDRIVER).is_file(), f"{APT} chromium-driver"),
    "selenium": (lambda: _importable("selenium"), "pip install -e '.[images]'"),
    "pillow": (lambda: _importable("PIL"), "pip install -e '.[images]'"),
    "rerun": (lambda: _rerun() is not None, "pip install -e . (rerun-sdk ships the viewer)"),
    "dot": (lambda: shutil.which("dot") is not None, f"{APT} graphviz"),
    "xvfb": (lambda: shutil.which("Xvfb") is not None, f"{APT} xvfb"),
    "vulkan": (
        lambda: any(Path("/usr/share/vulkan/icd.d").glob("lvp_icd*.json")),
        f"{APT} mesa-vulkan-drivers",
    ),
}
"""Tool -> (is it there?, how to install it)."""


def missing(scenes: list[Scene]) -> dict[str, str]:
    """The tools the scenes need that are not installed -> how to install each."""
    needed = dict.fromkeys(tool for scene in scenes for tool in scene.needs)
    return {tool: TOOLS[tool][1] for tool in needed if not TOOLS[tool][0]()}


# -- the pieces -----------------------------------------------------------------------------
def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _wait_port(port: int, proc: subprocess.Popen, log: Path, timeout_s: float = 30.0) -> None:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if proc.poll() is not None:
            raise RuntimeError(f"{proc.args[0]} exited: {log.read_text()[-2000:]}")
        with contextlib.suppress(OSError), socket.create_connection(("127.0.0.1", port), 0.2):
            return
        time.sleep(0.2)
    raise RuntimeError(f"nothing listens on 127.0.0.1:{port} after {timeout_s} s ({log})")


@contextlib.contextmanager
def _process(args: list[str], log: Path, env: dict[str, str] | None = None) -> Iterator:
    """A background process, stopped (terminate, then kill) when the block ends."""
    with log.open("w") as out:
        proc = subprocess.Popen(args, stdout=out, stderr=subprocess.STDOUT, env=env)
        try:
            yield proc
        finally:
            proc.terminate()
            try:
                proc.wait(10)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()


def _quiet_env() -> dict[str, str]:
    # CI=1: the viewer sends no usage analytics (there is no network here anyway)
    return {**os.environ, "CI": "1"}


@contextlib.contextmanager
def _web_viewer(work: Path, rrd: Path | None) -> Iterator[tuple[str, str]]:
    """`rerun --serve-web` on 127.0.0.1 (serving `rrd` if given): the page's URL and the
    gRPC URL an SDK streams to."""
    web, grpc = _free_port(), _free_port()
    args = [_rerun() or "rerun", "--serve-web", "--bind", "127.0.0.1"]
    args += ["--web-viewer-port", str(web), "--port", str(grpc)]
    args += [str(rrd)] if rrd is not None else []
    with _process(args, work / "serve-web.log", _quiet_env()) as proc:
        _wait_port(web, proc, work / "serve-web.log")
        _wait_port(grpc, proc, work / "serve-web.log")
        proxy = f"rerun+http://127.0.0.1:{grpc}/proxy"
        yield f"http://127.0.0.1:{web}/?url={proxy.replace('+', '%2B')}", proxy


@contextlib.contextmanager
def _browser() -> Iterator:
    """Headless Chromium driven by Selenium, a 1600x900 viewport, a fresh profile."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    with tempfile.TemporaryDirectory(prefix="chromium-") as profile:
        options = webdriver.ChromeOptions()
        options.binary_location = CHROMIUM
        for flag in (*CHROMIUM_FLAGS, f"--user-data-dir={profile}"):
            options.add_argument(flag)
        driver = webdriver.Chrome(service=Service(CHROMEDRIVER), options=options)
        try:
            _viewport(driver, WINDOW)
            yield driver
        finally:
            driver.quit()


def _viewport(browser, size: tuple[int, int]) -> None:
    """Make the page `size` (w, h) [px] (the viewer lays itself out again)."""
    w, h = size
    browser.execute_cdp_cmd(
        "Emulation.setDeviceMetricsOverride",
        {"width": w, "height": h, "deviceScaleFactor": 1, "mobile": False},
    )


def _png(browser, tries: int = 5):
    """A screenshot of the page. On a busy machine the software-rendered page may not answer
    in chromedriver's 10 s: asked again, up to `tries` times."""
    from PIL import Image
    from selenium.common.exceptions import TimeoutException

    for attempt in range(tries):
        try:
            return Image.open(io.BytesIO(browser.get_screenshot_as_png())).convert("RGB")
        except TimeoutException:
            if attempt == tries - 1:
                raise
            time.sleep(2.0)
    raise AssertionError("unreachable")


def _loaded(browser, timeout_s: float = 900.0, quiet_s: float = 6.0):
    """Wait until the viewer shows the whole recording: its time bar is drawn and the time
    panel (the bar and the latest time) has not changed for `quiet_s` (while data streams in,
    it grows, and the viewer follows it). Returns the time bar, or None."""
    deadline = time.monotonic() + timeout_s
    last, since = None, time.monotonic()
    while time.monotonic() < deadline:
        time.sleep(1.0)
        image = _png(browser)
        panel = np.asarray(image)[-40:]
        if last is None or not np.array_equal(panel, last):
            last, since = panel, time.monotonic()
        elif time.monotonic() - since >= quiet_s and _time_bar(image) is not None:
            time.sleep(2.0)  # the views draw
            return _time_bar(image)
    raise TimeoutError(f"the viewer did not settle within {timeout_s:.0f} s")


def _time_bar(image) -> tuple[int, int, int] | None:
    """The collapsed time panel's bar in a screenshot: the longest run of dark pixels in the
    bottom rows, at the middle of the rows it spans -> (y, x_start, x_end), or None."""
    rgb = np.asarray(image).astype(int)
    runs = []
    for y in range(rgb.shape[0] - 40, rgb.shape[0]):
        dark = np.concatenate([[False], rgb[y].sum(axis=1) < 200, [False]])
        edges = np.flatnonzero(np.diff(dark.astype(int)))
        if len(edges):
            k = int(np.argmax(edges[1::2] - edges[::2]))
            runs.append((int(edges[2 * k + 1] - edges[2 * k]), y, int(edges[2 * k])))
    if not runs or max(runs)[0] < rgb.shape[1] // 3:
        return None
    longest = max(runs)[0]
    rows = [r for r in runs if r[0] >= 0.95 * longest]
    length, y, x0 = rows[len(rows) // 2]
    return y, x0, x0 + length - 1


def _capture(browser, name: str, timeout_s: float = 900.0) -> Path:
    """Wait until the viewer shows the whole recording, save the PNG (zlib's best compression,
    ~10 % smaller than Pillow's default)."""
    _loaded(browser, timeout_s=timeout_s)
    out = IMAGES / f"{name}.png"
    _png(browser).save(out, optimize=True)
    return out


@contextlib.contextmanager
def _native_viewer(work: Path) -> Iterator[int]:
    """Rerun's native viewer on an Xvfb display, listening on 127.0.0.1: its port."""
    display = next(n for n in range(99, 200) if not Path(f"/tmp/.X11-unix/X{n}").exists())
    runtime = work / "xdg"
    runtime.mkdir(mode=0o700, exist_ok=True)
    env = {**_quiet_env(), "DISPLAY": f":{display}", "XDG_RUNTIME_DIR": str(runtime)}
    w, h = WINDOW
    xvfb = ["Xvfb", f":{display}", "-screen", "0", f"{w}x{h}x24", "-nolisten", "tcp"]
    port = _free_port()
    viewer = [_rerun() or "rerun", "--bind", "127.0.0.1", "--port", str(port)]
    viewer += ["--window-size", f"{w}x{h}"]
    with _process(xvfb, work / "xvfb.log"):
        time.sleep(1.0)
        with _process(viewer, work / "viewer.log", env) as proc:
            _wait_port(port, proc, work / "viewer.log")
            yield port


def _mcp(port: int, calls: list[tuple[str, dict]]) -> None:
    """Drive the native viewer through `rerun viewer-mcp` (JSON-RPC over stdio)."""
    args = [_rerun() or "rerun", "viewer-mcp", "--endpoint", f"http://127.0.0.1:{port}"]
    with subprocess.Popen(
        args,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
        env=_quiet_env(),
    ) as proc:
        assert proc.stdin is not None and proc.stdout is not None

        def send(message: dict) -> None:
            proc.stdin.write(json.dumps({"jsonrpc": "2.0", **message}) + "\n")
            proc.stdin.flush()

        def call(i: int, method: str, params: dict) -> dict:
            send({"id": i, "method": method, "params": params})
            reply = json.loads(proc.stdout.readline())
            if "error" in reply or reply.get("result", {}).get("isError"):
                raise RuntimeError(f"viewer-mcp {method} {params}: {reply}")
            return reply

        info = {"name": "make_images", "version": "1"}
        call(0, "initialize", {"protocolVersion": "2024-11-05", "capabilities": {},
                               "clientInfo": info})  # fmt: skip
        send({"method": "notifications/initialized"})
        # the viewer may still be busy with the run it was sent: connect, retrying for 60 s
        endpoint = {"endpoint": f"http://127.0.0.1:{port}"}
        for attempt in range(30):
            send({"id": 100 + attempt, "method": "tools/call",
                  "params": {"name": "rerun_connect", "arguments": endpoint}})  # fmt: skip
            reply = json.loads(proc.stdout.readline())
            if not reply.get("result", {}).get("isError"):
                break
            time.sleep(2.0)
        for i, (tool, arguments) in enumerate(calls, start=1):
            call(i, "tools/call", {"name": tool, "arguments": arguments})
            time.sleep(1.0)
        proc.stdin.close()
        proc.terminate()


def _record(scenario: str, seed: int, until_s: float | None = None, **recorder):
    """Run one episode with a Rerun recorder (`path=`, `connect=` or `spawn=`) that records
    the first `until_s` simulated seconds (None: all of it)."""
    from orchestrator.engine.runner import run_episode
    from orchestrator.language.load import load_scenario
    from orchestrator.recording import RerunRecorder

    class Until(RerunRecorder):
        """Records up to `until_s`, then only closes the recording at the end."""

        def on_step(self, ctx):
            if ctx.t <= until_s:
                super().on_step(ctx)

        def on_tick(self, ctx, executor):
            if ctx.t <= until_s + 1e-9:
                super().on_tick(ctx, executor)

        def _on_event(self, event):
            if event.t <= until_s + 1e-9:
                super()._on_event(event)

        def on_end(self, ctx, executor, result):
            if self._on_event in ctx.listeners:
                ctx.listeners.remove(self._on_event)
            self._flush()
            self.close()

    cls = RerunRecorder if until_s is None else Until
    return run_episode(load_scenario(scenario), seed, [cls(**recorder)])


def _terminate(signum: int, frame: object) -> None:
    raise KeyboardInterrupt(f"signal {signum}")


# -- main -----------------------------------------------------------------------------------
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("names", nargs="*", help="pictures to make (default: all)")
    parser.add_argument("--list", action="store_true", help="list the pictures and exit")
    args = parser.parse_args(argv)
    if args.list:
        for scene in SCENES:
            print(f"{scene.name:28s} {type(scene).__name__:15s} needs {', '.join(scene.needs)}")
        return 0
    known = {scene.name: scene for scene in SCENES}
    unknown = [n for n in args.names if n not in known]
    if unknown:
        print(f"unknown picture(s) {', '.join(unknown)} (valid: {', '.join(known)})")
        return 2
    scenes = [known[n] for n in args.names] or SCENES
    lacking = missing(scenes)
    if lacking:
        print("missing tools; install them and run again:")
        for tool, how in lacking.items():
            print(f"  {tool:13s} {how}")
        return 2
    IMAGES.mkdir(parents=True, exist_ok=True)
    failed: dict[str, str] = {}
    with tempfile.TemporaryDirectory(prefix="make_images-") as tmp:
        for scene in scenes:
            started = time.monotonic()
            print(f"{scene.name} ...", flush=True)
            work = Path(tmp) / scene.name
            work.mkdir()
            # an interrupt or a kill unwinds the blocks that stop the browser and the viewers
            signal.signal(signal.SIGINT, signal.default_int_handler)
            signal.signal(signal.SIGTERM, _terminate)
            try:
                out = scene.render(work)
            except Exception as exc:  # noqa: BLE001 - one picture's failure must not stop the rest
                first = (str(exc).strip().splitlines() or [""])[0]
                failed[scene.name] = f"{type(exc).__name__}: {first}"
                print(f"  FAILED: {failed[scene.name]}", flush=True)
                continue
            print(f"  {out.relative_to(IMAGES.parent.parent)} ({time.monotonic() - started:.0f} s)")
    if failed:
        print(f"{len(failed)} of {len(scenes)} pictures could not be made (the others were):")
        for name, why in failed.items():
            print(f"  {name}: {why}")
        return 1
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except KeyboardInterrupt as stop:
        print(f"interrupted ({stop or 'Ctrl-C'}): browser and viewers stopped")
        sys.exit(130)
