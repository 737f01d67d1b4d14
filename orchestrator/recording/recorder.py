"""RerunRecorder: the run observer that writes an episode to a Rerun recording."""

from __future__ import annotations

import uuid
import warnings
from pathlib import Path
from typing import TYPE_CHECKING

import rerun as rr

from .batches import TemporalBatch
from .blueprint import default_blueprint
from .camera_shots import CameraShots
from .events import EventLog
from .exceptions import RecordingError
from .framing import work_frame
from .guard_margins import GuardMargins, declared_guards
from .paths import RESULT
from .reshaped import ReshapedGeoms
from .signals import RobotSignals
from .state_log import StateLog
from .static_scene import static_scene
from .targets import Targets
from .timeline import Rows
from .viewer import connect_url, reachable, spawn_viewer, viewer_url

if TYPE_CHECKING:
    from ..engine.context import Context, Event
    from ..engine.executor import Executor
    from ..engine.result import RunResult

__all__ = ["APPLICATION_ID", "RerunRecorder"]

APPLICATION_ID = "embodied_orchestrator"
"""Rerun application id of every recording: the viewer keeps one blueprint per application."""

_RESULT_LEVEL = {"succeeded": "INFO", "failed": "WARN", "aborted": "ERROR", "error": "ERROR"}


class RerunRecorder:
    """Records one episode at a time to Rerun; pass it to `run_episode` as an observer.

    Each episode gets its own `rr.RecordingStream` (never the global one, so batch workers
    record episodes independently). Nothing is logged row by row on the control loop: static
    geometry, frames and the machine graph are prepared in `on_start`; body poses, signals,
    guard margins, state changes and events are buffered every control tick and sent as
    column batches every `flush_every_ticks` ticks and at the end.

    The stream opens at the first send: at once when live (`spawn` or `connect`: the viewer
    shows the scene from the start), else at the first flush (for most episodes `on_end`), so
    Rerun's writer threads never compete with the simulation. `on_end` closes it: the file is
    complete when `run_episode` returns. Construction has no side effects. A recorder may be
    reused for consecutive episodes (each gets a new recording; a fixed `path` is overwritten).

    Args:
        path: Save the recording to this `.rrd` file (parent directories are created).
        spawn: Start a Rerun viewer and stream to it live.
        connect: Stream live to a viewer or `rerun --serve-web` server already running: its
            gRPC URL (`rerun+http://127.0.0.1:9876/proxy`) or port.
        application_id: Rerun application id.
        recording_id: Id of the recording (default: a fresh random id per episode).
        flush_every_ticks: Send buffered data every N control ticks. Default: 20 when live
            (the viewer follows the run), else 1000 (bounds memory on long episodes).
        port: TCP port of the spawned viewer.

    Every sink receives the default blueprint, made active: a viewer shows the designed
    layout whichever way the recording reaches it (see docs/recording.md).

    Raises:
        RecordingError: None of `path`, `spawn` and `connect` was given, or `connect` is not
            a Rerun address.
    """

    def __init__(
        self,
        path: str | Path | None = None,
        spawn: bool = False,
        *,
        connect: str | None = None,
        application_id: str = APPLICATION_ID,
        recording_id: str | None = None,
        flush_every_ticks: int | None = None,
        port: int = 9876,
    ) -> None:
        if path is None and not spawn and connect is None:
            raise RecordingError(
                "nothing to record to: pass path=<file.rrd>, spawn=True or connect=<url>"
            )
        if flush_every_ticks is not None and flush_every_ticks < 1:
            raise RecordingError(f"flush_every_ticks must be >= 1 (got {flush_every_ticks})")
        self.path = Path(path) if path is not None else None
        self.spawn = spawn
        self.connect = connect_url(connect) if connect is not None else None
        self.application_id = application_id
        self.recording_id = recording_id
        self.live = spawn or connect is not None
        self.flush_every_ticks = flush_every_ticks or (20 if self.live else 1000)
        self.port = port
        self.rec: rr.RecordingStream | None = None

    # -- observer hooks -------------------------------------------------------------------
    def on_start(self, ctx: Context, executor: Executor) -> None:
        """Prepare everything static (world, frames, machine graph); open the stream if live."""
        self._begin(ctx, executor, None)

    def on_resume(self, ctx: Context, executor: Executor) -> None:
        """A run resumed from a snapshot (`run --from`): the recording starts at the snapshot's
        time, in the state active then, with a `resume` event marking it."""
        self._begin(ctx, executor, executor.leaf)

    def _begin(self, ctx: Context, executor: Executor, resumed_in: str | None) -> None:
        self._ctx, self._executor = ctx, executor
        self.rec = None
        scene = static_scene(ctx, executor.root)
        self._static = scene.chunks
        self._graph_bounds = scene.graph.bounds
        self._frame = work_frame(ctx)
        self._poses = scene.poses
        self._states = StateLog(scene.graph)
        self._signals = RobotSignals(ctx)
        self._true_sq = ctx.cell.wrist.true_norm_sq
        self._peak_sq = -1.0
        """Largest true |F|^2 [N^2] after a physics step since the last row (-1: none)."""
        self._targets = Targets()
        # the per-tick table: one row per control tick, shared by poses and signals
        self._rows = Rows({**self._poses.fields, **self._signals.fields})
        self._guard_names = declared_guards(
            executor.root, executor.active_guards, getattr(ctx.scenario, "guards", None)
        )
        self._guards = GuardMargins()
        self._guards.plan(executor.active_guards, ctx.tick, float(ctx.data.time))
        self._events = EventLog()
        self._shots = CameraShots(ctx)
        self._reshaped = ReshapedGeoms(ctx.model, scene.reshaped)
        for g in scene.skipped:
            self._events.add_text(
                ctx.tick, ctx.t, "recorder", f"geom {g}: an SDF without a mesh is not drawn", "WARN"
            )
        self._seen = 0
        self._last_tick, self._last_t = -1, 0.0
        self._guards.trip_line(ctx.tick, ctx.t)
        self._resumed_at = None if resumed_in is None else ctx.t
        if resumed_in is None:
            self._states.enter(ctx.tick, ctx.t, self._states.graph.initial_leaf)
        else:  # what happened before the snapshot is in the recording of the run up to it
            self._seen = len(executor.transitions)
            self._states.enter(ctx.tick, ctx.t, resumed_in)
            self._events.add_text(
                ctx.tick, ctx.t, "resume", f"resumed from a snapshot at t={ctx.t:.3f} s "
                f"(control tick {ctx.tick}) in {resumed_in}", "INFO",
            )  # fmt: skip
        ctx.listeners.append(self._on_event)
        if self.live:
            self._flush()

    def on_step(self, ctx: Context) -> None:
        """After every physics step: keep the peaks a control tick would miss (the true wrist
        force, the guards in `STEP_PEAK_GUARDS`). About 1 us per step; a run without a
        recorder does not call it."""
        f = self._true_sq()
        if f > self._peak_sq:  # noqa: PLR1730 (cheaper than max() per step)
            self._peak_sq = f
        if self._guards.stepping:
            self._guards.on_step(ctx)

    def on_tick(self, ctx: Context, executor: Executor) -> None:
        """Buffer this control tick: poses, signals, guard margins, target changes."""
        if self._seen < len(executor.transitions):
            self._catch_up(ctx.tick)
        self._sample(ctx, executor)
        if self._rows.n >= self.flush_every_ticks:
            self._flush()

    def on_end(self, ctx: Context, executor: Executor, result: RunResult) -> None:
        """Log the final state and the result, send everything and close the recording."""
        self._catch_up(ctx.tick)
        if self._last_tick != ctx.tick:
            self._sample(ctx, executor)
        text = f"{result.outcome} in {result.final_state} after {result.sim_time:.3f} s"
        reason = result.reason
        if reason and "guard" in reason:
            text += f", aborted by {reason.get('guard')}: {reason.get('message')}"
        elif reason:  # the time limit (or the wall-clock limit)
            text += f", stopped by {reason.get('kind')}: {reason.get('message')}"
        self._events.add_text(ctx.tick, ctx.t, "result", text, _RESULT_LEVEL[result.outcome])
        self._flush()
        if self.rec is not None:  # static: shown wherever the time cursor is
            self.rec.log(RESULT, rr.TextDocument(f"**{text}**", media_type="text/markdown"),
                         static=True)  # fmt: skip
        if self._on_event in ctx.listeners:
            ctx.listeners.remove(self._on_event)
        self.close()

    def close(self) -> None:
        """Flush and close the sinks (the `.rrd` file is complete afterwards)."""
        if self.rec is not None:
            self.rec.disconnect()  # flushes, then closes: the file is complete
            self.rec = None

    # -- internals ------------------------------------------------------------------------
    def _open(self, ctx: Context) -> rr.RecordingStream:
        rec = rr.RecordingStream(
            self.application_id,
            recording_id=self.recording_id or uuid.uuid4().hex,
            send_properties=False,  # they carry the wall-clock start time: not reproducible
        )
        sinks: list[rr.FileSink | rr.GrpcSink] = []
        if self.spawn:
            if spawn_viewer(rec, self.port):
                sinks.append(rr.GrpcSink(viewer_url(self.port)))
            elif self.path is None:
                raise RecordingError(
                    f"no Rerun viewer came up on port {self.port} (is there a display?);"
                    " save the recording with --rrd PATH and open it with `rerun PATH`"
                )
            else:
                warnings.warn(
                    f"no Rerun viewer came up on port {self.port}; recording to {self.path} only",
                    RuntimeWarning,
                    stacklevel=2,
                )
        if self.connect is not None:
            if not reachable(self.connect):
                raise RecordingError(
                    f"no Rerun viewer or server at {self.connect}: start one first (`rerun`, or"
                    " `rerun --serve-web` for a browser), or record with --rrd PATH"
                )
            sinks.append(rr.GrpcSink(self.connect))
        if self.path is not None:
            try:
                self.path.parent.mkdir(parents=True, exist_ok=True)
            except OSError as exc:
                raise RecordingError(f"cannot write the recording to {self.path}: {exc}") from None
            sinks.append(rr.FileSink(str(self.path)))
        rec.set_sinks(*sinks)
        resumed = "" if self._resumed_at is None else f", resumed at t={self._resumed_at:.3f} s"
        rec.send_recording_name(f"{ctx.scenario.name} seed {ctx.world.seed}{resumed}")
        return rec

    def _on_event(self, event: Event) -> None:
        tick = self._ctx.tick
        self._catch_up(tick)
        self._events.add(tick, event)
        data = event.data or {}
        if event.kind == "violation" and "guard" in data:  # logged in the step that fired
            self._guards.tripped(
                tick, event.t, self._ctx, str(data["guard"]), data.get("value"), data.get("limit")
            )

    def _catch_up(self, tick: int) -> None:
        """Turn transitions recorded since the last call into state entries at `tick`."""
        transitions = self._executor.transitions
        while self._seen < len(transitions):
            tr = transitions[self._seen]
            self._seen += 1
            self._states.enter(tick, float(tr["t"]), str(tr["to"]))

    def _sample(self, ctx: Context, executor: Executor) -> None:
        tick, t = ctx.tick, float(ctx.data.time)
        i = self._rows.append(tick, t)
        self._poses.sample(self._rows, i, ctx.data)
        self._signals.sample(self._rows, i, ctx, self._peak_sq)
        self._peak_sq = -1.0
        self._guards.plan(executor.active_guards, tick, t)
        self._guards.sample(tick, t, ctx)
        self._targets.sample(tick, t, ctx)
        self._shots.sample()
        self._reshaped.sample(tick, t)
        self._last_tick, self._last_t = tick, t

    def _flush(self) -> None:
        """Send everything buffered as chunks. The per-tick table (the largest) goes first, so
        Rerun's writer thread encodes it while the rest is built; on the first call the stream
        is opened just before it, and the blueprint and the static data follow it."""
        chunks = []
        if self._rows.n:
            ticks, t_s, values = self._rows.take()
            table = TemporalBatch(ticks, t_s)
            error = self._signals.add_columns(table, values, t_s, ticks)
            chunks = table.chunks() + (error.chunks() if error is not None else [])
            chunks += self._poses.chunks(ticks, t_s, values)
        first = self.rec is None
        if self.rec is None:
            self.rec = self._open(self._ctx)
        self.rec.send_chunks(chunks)
        if first:
            self.rec.send_blueprint(
                default_blueprint(
                    self._frame,
                    self._graph_bounds,
                    [c.name for c in self._ctx.scenario.cameras],
                    self._guard_names,
                ),
                make_active=True,
                make_default=True,
            )
            self.rec.send_chunks(self._static)
            self.rec.log(RESULT, rr.TextDocument("running (how it ends shows here)"), static=True)
        if self._last_tick >= 0:  # the trip line at 1.0 reaches the last row sent
            self._guards.trip_line(self._last_tick, self._last_t)
        chunks = self._guards.chunks()
        chunks += self._targets.chunks()
        chunks += self._states.chunks()
        chunks += self._events.chunks()
        chunks += self._reshaped.chunks()
        self.rec.send_chunks(chunks)
        self._shots.log(self.rec)
