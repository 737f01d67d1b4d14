"""The skill API reference, docs/skill-api.md, generated from the docstrings of what a skill
may use: the `Skill` base, the `Context` every skill method is handed, the controller it
commands and the `SuccessCheck` base.

Each member's text is its docstring (a property's, a method's, or the string literal after
an attribute's assignment, as Sphinx reads them); this module only says where on the page it
goes, where it may be used and what it costs (figures: bench/skill_api_costs.py).
tests/test_skill_api.py fails when the page is stale or a public member of Context or Skill
has no docstring or no place here.

    python -m orchestrator.engine.skill_api    # regenerate docs/skill-api.md
"""

from __future__ import annotations

import ast
import inspect
import re
import textwrap
from dataclasses import dataclass
from pathlib import Path

from ..robots import Controller
from ..skills import Skill, SkillParams
from ..skills.ik import IKSolver
from ..success import CheckParams, SuccessCheck, Verdict
from ..world.pose import Pose
from ..world.world import ObjectHandle
from .blackboard import Blackboard
from .context import Context

__all__ = ["PAGE", "SECTIONS", "Member", "Section", "member_doc", "public_members", "skill_api"]

PAGE = Path(__file__).resolve().parent.parent.parent / "docs" / "skill-api.md"
"""Where the page lives in a clone."""

ANY = "start, step, stop"
"""Any of the lifecycle methods of a skill (and `explain`)."""
FRAMEWORK = "framework only"
"""The runner, the guards or the recorder use it; a skill must not call or write it."""


@dataclass(frozen=True)
class Member:
    """One member as the page lists it.

    Attributes:
        name: The attribute, property or method name.
        where: Where a skill may use it (`ANY`, `FRAMEWORK`, or a note).
        cost: What it costs per call, in words and figures.
    """

    name: str
    where: str = ANY
    cost: str = "free (a stored value)"


@dataclass(frozen=True)
class Section:
    """A group of members of one class.

    Attributes:
        title: The section's heading.
        cls: The class the members belong to.
        prefix: How a skill reaches them (`ctx.`, `self.`).
        intro: A paragraph before the table.
        members: The members, in the page's order.
    """

    title: str
    cls: type
    prefix: str
    intro: str
    members: tuple[Member, ...]


_VIEW = "free: a view of MuJoCo's state (read it now or copy it; it changes as the arm moves)"
_COPY = "~4 us (a copy of the encoder reading)"
SECTIONS: tuple[Section, ...] = (
    Section(
        "`Skill`: what you write",
        Skill,
        "self.",
        "Subclass it in a module of your own (`from orchestrator.skills import Skill, "
        "SkillParams`). The framework owns the loop: `start` once on entry, `step` every "
        "control tick until it returns an outcome, `stop` on exit — also when a guard "
        "aborts, a timeout fires or an event preempts the state. "
        "A skill never blocks and never steps physics. An exception out of any of them ends "
        "the run `error` (exit 4) with the skill's file:line.",
        (
            Member("name", "class attribute"),
            Member("Params", "class attribute"),
            Member("outcomes", "class attribute"),
            Member("explained", "class attribute"),
            Member("writes", "class attribute"),
            Member("needs_scene", "class attribute"),
            Member("params", ANY),
            Member("start", "called once, on entry", "yours: keep it under a tick (10 ms)"),
            Member("step", "called every control tick", "yours: keep it well under 10 ms"),
            Member("stop", "called once, on exit", "yours"),
            Member("explain", "called before `stop` after a failure outcome or a timeout", "yours"),
            Member("written_keys", FRAMEWORK, "free"),
            Member(
                "snapshot_state",
                "called when a run snapshot is written or checked (override: state of your own)",
                "yours: plain data only",
            ),
            Member(
                "restore_state",
                "called once when a run resumes from a snapshot, instead of `start`",
                "yours: override with `snapshot_state`",
            ),
        ),
    ),
    Section(
        "Time",
        Context,
        "ctx.",
        "Simulated time only: a skill never reads the wall clock. Measure durations on "
        "`ctx.clock`, which a `pause` stops and a `resume` continues; `ctx.t` keeps running "
        "through a pause (a wait measured on it ends while the arm is held).",
        (
            Member("clock", ANY, "~0.4 us"),
            Member("t", ANY, "~0.3 us"),
            Member("clock_rate", ANY),
            Member("dt_control", ANY),
            Member("dt_physics", ANY),
            Member("tick", ANY),
            Member("clock_offset", FRAMEWORK),
        ),
    ),
    Section(
        "Sensing the robot",
        Context,
        "ctx.",
        "What the robot's own sensors read — encoders (quantized with `physics.realism`), the "
        "wrist force/torque sensor (with its noise, drift and injected faults) — in the world "
        "frame, SI units.",
        (
            Member("q", ANY, _COPY),
            Member("qd", ANY, "~5 us (a copy of the encoder reading)"),
            Member("robot_q", ANY, "~0.5 us (the reading itself: copy before keeping it)"),
            Member("tcp_pos", ANY, _VIEW),
            Member("tcp_rot", ANY, _VIEW),
            Member("gripper_width", ANY, "~1 us"),
            Member("wrist_force", ANY, "~3 us"),
            Member("wrist_force_norm_sq", ANY, "~1 us (computed once per physics step)"),
            Member("wrist_force_age_s", ANY, "free"),
            Member("joint_torque", ANY, "~1 us (a view: copy it to keep it)"),
        ),
    ),
    Section(
        "Commanding the robot",
        Context,
        "ctx.",
        "Setpoints only: the controller turns them into joint torques every physics step "
        "(500 Hz) and the guards watch the arm while it does. A skill's last setpoint stays "
        "in force until another one replaces it (the default `stop` holds the current pose).",
        (
            Member("controller", ANY, "~4 us per `hold` or `set_joint_target` call"),
            Member("ik", ANY, "a solve (`ctx.ik.step`) ~0.7 ms: once per tick at most"),
            Member("set_gripper", ANY, "free"),
            Member("gripper_commanded", ANY, "~1 us"),
            Member("gripper_target", "read anywhere; write through `set_gripper`"),
            Member("grasped_at", "read anywhere; a grasp skill writes it when it closes", "free"),
            Member("zero_wrist_force", "at rest, once (e.g. a `zero_sensor` skill)", "~2 us"),
        ),
    ),
    Section(
        "The world",
        Context,
        "ctx.",
        "`object_pose` is ground truth: what a perception skill starts from before it adds "
        "its noise (`search`) or what a camera sees (`detect`). A skill that stands for "
        "perception passes its result through `perceived`, so injected perception faults "
        "reach it.",
        (
            Member("object_pose", ANY, "~8 us (builds a Pose)"),
            Member("start_pose", ANY, "~20 us (draws the scene's poses again; builds a Pose)"),
            Member("object_handle", ANY, "free (half sizes, ids)"),
            Member("perceived", ANY, "free without a perception fault"),
            Member("cameras", ANY, "a frame (`cameras.capture`) ~10 ms: not every tick"),
            Member("world", ANY),
            Member("robot", ANY),
            Member("scenario", ANY),
            Member("workspace_box", "read only (a recovery skill backs the TCP into it)"),
            Member("model", "read only (ground truth)"),
            Member("data", "read only (ground truth; never step or write it)"),
            Member("rng", ANY, "~1 us per draw"),
        ),
    ),
    Section(
        "Sharing and reporting",
        Context,
        "ctx.",
        "The blackboard is how states hand values to each other (`into:` parameters write "
        "it, `$key` reads it); `log` and `metrics` end up in the result and the recording.",
        (
            Member("blackboard", ANY, "~5 us per `resolve`; item access ~0.1 us"),
            Member("log", ANY, "~4 us"),
            Member("metrics", ANY),
            Member("tasks", "task skills (`next_task`, `end_task`)"),
            Member("ik_target", "motion skills: set it to the pose they drive to"),
            Member("planned_path", "motion skills: set it to the path they follow"),
            Member("trace", "contact skills: set it while tracing"),
            Member("keep_camera_shots", "read it before keeping frames"),
            Member("camera_shots", "append `(tick, t, Frame, detections)` while kept"),
            Member("events", "read only"),
        ),
    ),
    Section(
        "The framework's",
        Context,
        "ctx.",
        "Public because the runner, the guards, the fault injector or the recorder use them: a "
        "skill must not call or write them. What lives as long as the world — the encoders, "
        "the wrist sensor's noise, fault and true reading, the hand's drive, the injected "
        "hardware faults, the step loop — is the cell's (`ctx.cell`, engine/cell.py), not the "
        "episode's.",
        (
            Member("listeners", FRAMEWORK),
            Member("cell", FRAMEWORK),
        ),
    ),
    Section(
        "`ctx.controller`: the torque controller",
        Controller,
        "ctx.controller.",
        "The controller runs on its own model of the robot (pinocchio, from the same URDF), "
        "never on MuJoCo's ground truth. These are the calls a skill makes; the rest of its "
        "members are the runner's and the controlled stop's.",
        (
            Member("hold", ANY, "~4 us"),
            Member("set_joint_target", ANY, "~4 us"),
            Member("hold_setpoint", ANY, "~4 us"),
            Member("set_cartesian_target", ANY, "~4 us; each physics step then costs a Jacobian"),
            Member("tcp_pose", ANY, "~20 us (forward kinematics)"),
            Member("q_d", "read only"),
        ),
    ),
    Section(
        "`ctx.ik`: the IK solver motion skills share",
        IKSolver,
        "ctx.ik.",
        "Differential IK of the TCP on the robot's own kinematic model (mink's QP), with a "
        "limiter that keeps its command within the joints' speed, acceleration and jerk. "
        "Seed it from the measured joints (`reset(ctx.q)`), then call `step(pos, rot)` once "
        "per control tick with the world pose the TCP should have and hand its result to "
        "`ctx.controller.set_joint_target`; the bundled `move` skill "
        "(orchestrator/skills/move.py) is the worked example. One solver serves every skill "
        "of a run: a skill that uses it starts with `reset`. Joint vectors have shape "
        "`(n,)` [rad].",
        (
            Member("reset", "start (before the first `step`)", "no QP solve"),
            Member("step", "step: once per tick at most", "a QP solve, ~0.7 ms"),
            Member("reference_step", "step: once per tick at most", "a QP solve, ~0.7 ms"),
            Member("follow", "step: once per tick at most", "no QP solve"),
            Member("hold", "step: once per tick at most", "no QP solve"),
            Member("restart_from", ANY, "no QP solve"),
            Member("set_posture", ANY, "no QP solve"),
            Member("q", ANY),
            Member("command", ANY),
            Member("velocity", "read only"),
            Member("acceleration", "read only"),
            Member("reference_velocity", "read only"),
            Member("error", ANY),
            Member("lag", ANY),
            Member("tcp_pose", ANY, "forward kinematics of the robot-only model"),
            Member("limiter", "read only (its limits bound a joint move: `move_joints`)"),
            Member("n", "read only"),
            Member("dt", "read only"),
            Member("base_pos", "read only"),
            Member("robot", "read only"),
            Member("posture_follows_reset", "whole-body solvers set it"),
            Member("config", FRAMEWORK),
            Member("frame_task", FRAMEWORK),
            Member("posture_task", FRAMEWORK),
            Member("tasks", FRAMEWORK),
            Member("limits", FRAMEWORK),
            Member("damping", FRAMEWORK),
            Member("snapshot_state", "a run snapshot records it", FRAMEWORK),
            Member("restore_state", "a resumed run puts it back", FRAMEWORK),
        ),
    ),
    Section(
        "`Pose`: a position and an orientation",
        Pose,
        "pose.",
        "`from orchestrator.world.pose import Pose`. What `ctx.object_pose`, "
        "`ctx.start_pose` and the perception skills return, what a `type: pose` blackboard "
        "key holds and what a motion's target becomes: a frozen pydantic model "
        '(`Pose(pos=[0.5, 0.0, 0.3])`, `pose.model_copy(update={"pos": ...})`).',
        (
            Member("pos", ANY),
            Member("quat", ANY),
            Member("yaw", ANY, "~2 us"),
            Member("coerce", ANY, "free for a Pose; a validation otherwise"),
        ),
    ),
    Section(
        "`ctx.object_handle(name)`: where a scene object is in the model",
        ObjectHandle,
        "handle.",
        "Indices into `ctx.model` and `ctx.data` (ground truth: for success checks, guards "
        "and the framework; a skill that perceives goes through `ctx.perceived`).",
        (
            Member("name", ANY),
            Member("body_id", ANY),
            Member("geom_id", ANY),
            Member("qpos_adr", ANY),
            Member("qvel_adr", ANY),
            Member("half_size", ANY),
        ),
    ),
    Section(
        "`ctx.blackboard`: the values states share",
        Blackboard,
        "ctx.blackboard.",
        "Keys are the machine's `blackboard:` declarations. `ctx.blackboard[key]` reads one "
        "(a missing key is an error naming the keys there are), `ctx.blackboard[key] = "
        "value` writes one (a skill writes only the keys its `into:` parameters name), `key "
        "in ctx.blackboard` tests one.",
        (
            Member("get", ANY, "~0.1 us"),
            Member("resolve", ANY, "~5 us"),
            Member("as_dict", ANY, "a copy of every value"),
        ),
    ),
    Section(
        "`SuccessCheck`: a success criterion of your own",
        SuccessCheck,
        "self.",
        "Subclass it (`from orchestrator.success import CheckParams, SuccessCheck, Verdict`) "
        "in a module of a folder a scenario's `skills:` loads; [success-checks.md](success-"
        "checks.md) builds one. It is evaluated once, after the run, with the same `ctx`.",
        (
            Member("kind", "class attribute"),
            Member("Params", "class attribute"),
            Member("params", "evaluate, metrics"),
            Member("evaluate", "called once, at the end of the run", "yours"),
            Member("metrics", "called once, at the end of the run", "yours"),
            Member(
                "snapshot_state",
                "called when a run snapshot is written or checked",
                "yours: plain data only",
            ),
            Member(
                "restore_state",
                "called once when a run resumes from a snapshot",
                "yours: override with `snapshot_state`",
            ),
        ),
    ),
)
"""The page, section by section."""

_EXTRA = (SkillParams, CheckParams, Verdict)
"""Classes shown by their docstring alone."""


def _attribute_docs(cls: type) -> dict[str, str]:
    """Attributes and their docstrings: the string literal after `name: T = ...` in the class
    body and after `self.name = ...` in `__init__` (public names only; "" if none)."""
    try:
        tree = ast.parse(textwrap.dedent(inspect.getsource(cls)))
    except (OSError, TypeError):
        return {}
    out: dict[str, str] = {}
    body = tree.body[0].body if tree.body and isinstance(tree.body[0], ast.ClassDef) else []
    init = next((n for n in body if isinstance(n, ast.FunctionDef) and n.name == "__init__"), None)
    for block, owner in ((body, None), (init.body if init else [], "self")):
        for i, node in enumerate(block):
            target: ast.expr | None = None
            if isinstance(node, ast.AnnAssign):
                target = node.target
            elif isinstance(node, ast.Assign) and len(node.targets) == 1:
                target = node.targets[0]
            name = _assigned_name(target, owner)
            if name is None or name.startswith("_"):
                continue
            after = block[i + 1] if i + 1 < len(block) else None
            doc = ""  # an attribute without a docstring is listed too: the test finds it
            if isinstance(after, ast.Expr) and isinstance(after.value, ast.Constant):
                if isinstance(after.value.value, str):
                    doc = inspect.cleandoc(after.value.value)
            if doc or name not in out:
                out[name] = doc
    return out


def _assigned_name(target: ast.expr | None, owner: str | None) -> str | None:
    if owner is None:
        return target.id if isinstance(target, ast.Name) else None
    if isinstance(target, ast.Attribute) and isinstance(target.value, ast.Name):
        return target.attr if target.value.id == owner else None
    return None


def public_members(cls: type) -> set[str]:
    """Every public attribute, property and method of `cls` (its own and inherited from the
    framework's bases, not `object`'s), and the attributes `__init__` sets."""
    names = {n for n in dir(cls) if not n.startswith("_")}
    names -= {n for n in dir(object)}
    if issubclass(cls, SkillParams):
        names -= set(dir(SkillParams.__mro__[1]))  # pydantic's own
    return names | set(_attribute_docs(cls))


def member_doc(cls: type, name: str) -> str:
    """The docstring of `cls.name` (empty if it has none)."""
    attributes = _attribute_docs(cls)
    if name in attributes:
        return attributes[name]
    member = inspect.getattr_static(cls, name, None)
    if isinstance(member, property):
        return inspect.getdoc(member) or ""
    if callable(member) or isinstance(member, (classmethod, staticmethod)):
        return inspect.getdoc(getattr(cls, name)) or ""
    return ""


def _signature(cls: type, name: str) -> str:
    member = inspect.getattr_static(cls, name, None)
    if isinstance(member, property):
        kind = "property"
        returns = inspect.signature(member.fget).return_annotation if member.fget else ""
        return f"{kind} → `{returns}`" if returns is not inspect.Signature.empty else kind
    if callable(member) and not isinstance(member, type):
        sig = inspect.signature(getattr(cls, name))
        text = ", ".join(_parameter(p) for p in sig.parameters.values() if p.name != "self")
        ret = sig.return_annotation
        ret_text = "" if ret is inspect.Signature.empty else f" -> {ret}"
        return f"`{name}({text}){ret_text}`"
    return "attribute"


def _parameter(p: inspect.Parameter) -> str:
    """`name: type = default` as written (annotations are strings: postponed evaluation)."""
    text = f"**{p.name}" if p.kind is p.VAR_KEYWORD else p.name
    if p.annotation is not p.empty:
        text += f": {p.annotation}"
    if p.default is not p.empty:
        text += f" = {p.default!r}"
    return text


def _cell(text: str) -> str:
    return " ".join(text.split()).replace("|", "\\|")


def _section(section: Section) -> list[str]:
    lines = [f"## {section.title}", "", section.intro, ""]
    lines += ["| member | kind | what it is | where | cost |", "|---|---|---|---|---|"]
    for m in section.members:
        doc = member_doc(section.cls, m.name)
        lines.append(
            f"| `{section.prefix}{m.name}` | {_cell(_signature(section.cls, m.name))} | "
            f"{_cell(doc)} | {_cell(m.where)} | {_cell(m.cost)} |"
        )
    return [*lines, ""]


_HEAD = """\
# The skill API

<!-- Generated from the docstrings by `python -m orchestrator.engine.skill_api`;
tests/test_skill_api.py fails when it is stale. Do not edit by hand. -->

Everything a skill (or a success check) may use, with units, frames, where in the lifecycle
it may be used and what it costs. Every method of a skill is handed `ctx`, the running
episode: it reads the robot through its sensors, commands it through setpoints, and shares
values through the blackboard. A control tick is 10 ms of simulated time (100 Hz); a skill's
`step` should take well under that in wall time too, so the run keeps pace. Costs are wall
time per call on one core, measured by `python bench/skill_api_costs.py` (orders of
magnitude: they vary with the machine and its load). Positions are in the world frame [m],
rotations are 3x3 matrices or quaternions (w, x, y, z), angles [rad] unless a name says
`_deg`. The tutorial writes a first skill: [tutorial-first-flow.md](tutorial-first-flow.md).
"""


def skill_api() -> str:
    """docs/skill-api.md."""
    lines = [_HEAD]
    for section in SECTIONS:
        lines += _section(section)
    for cls in _EXTRA:
        doc = re.split(r"\n\s*\n", inspect.getdoc(cls) or "")[0]
        lines += [f"## `{cls.__name__}`", "", " ".join(doc.split()), ""]
    return "\n".join(lines).rstrip() + "\n"


if __name__ == "__main__":
    PAGE.write_text(skill_api())
    print(f"wrote {PAGE}")
