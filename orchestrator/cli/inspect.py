"""The reading commands: `validate`, `graph`, `schema`, `list`, `show` (no physics is loaded:
tests/test_startup.py)."""

# No `from __future__ import annotations`: typer reads the parameter annotations of every
# command each time the CLI starts; as strings, each would be compiled and evaluated again
# (cli/__init__.py).
import sys
from pathlib import Path
from typing import Annotated

import typer

from ..exceptions import ConfigError
from .console import err, escape, out, plain
from .errors import EXIT_INVALID, fail_config
from .options import AllowPathOption, SkillPaths, allowed_dirs, note_entry, use_skills


def validate(
    paths: Annotated[
        list[str],
        typer.Argument(help="Machine or scenario files, folders of them, or bundled names."),
    ],
    allow_path: AllowPathOption = None,
    skills: SkillPaths = None,
) -> None:
    """Check machines and scenarios without simulating: all errors at once, exit 2 if any.
    Runs no code a file names: a scenario's `skills:` are not imported (pass --skills DIR)."""
    from ..language.validate_paths import validate_paths

    use_skills(skills)
    try:
        problems, checked = validate_paths(paths, allowed_dirs(allow_path))
    except ConfigError as exc:  # e.g. a bad $ORCHESTRATOR_LIMITS
        problems, checked = exc.diagnostics, []
    if problems:
        fail_config(ConfigError(problems))
    for kind, name in checked:
        plain(f"ok  {kind:8} {name}")


def graph(
    machine: Annotated[
        str, typer.Argument(help="Machine file or bundled name, or a scenario (its machine).")
    ],
    fmt: Annotated[
        str, typer.Option("--format", help="mermaid (no system package needed) or dot (Graphviz).")
    ] = "mermaid",
    allow_path: AllowPathOption = None,
    skills: SkillPaths = None,
) -> None:
    """Draw a machine: states, outcome-labelled transitions, nested clusters, the abort path."""
    from ..language.entries import file_kind, unknown_entry
    from ..language.graph import to_dot, to_mermaid
    from ..language.load import load_machine, load_scenario

    if fmt not in ("mermaid", "dot"):
        err.print(f"--format: unknown format {fmt[:80]!r} (valid: mermaid, dot)", markup=False)
        raise typer.Exit(EXIT_INVALID)
    use_skills(skills)
    note_entry(machine)
    try:
        kind = file_kind(machine)
        if kind is None:
            raise ConfigError([unknown_entry(machine, "<machine>")])
        if kind[0] == "scenario" and not Path(machine).is_file():  # a bundled scenario
            node = load_scenario(machine, import_skills=False).machine
        elif kind[0] == "scenario":
            loaded = load_scenario(
                machine, allow_paths=allowed_dirs(allow_path), import_skills=False
            )
            err.print(
                f"{machine} is a scenario: drawing its machine {loaded.scenario.machine!r}",
                markup=False,
                soft_wrap=True,
            )
            node = loaded.machine
        else:
            node = load_machine(machine, allow_paths=allowed_dirs(allow_path))
    except ConfigError as exc:
        fail_config(exc, "nothing was drawn")
        return
    sys.stdout.write(to_mermaid(node) if fmt == "mermaid" else to_dot(node))


def schema(
    kind: Annotated[str, typer.Argument(help="machine or scenario")],
    skills: SkillPaths = None,
) -> None:
    """Print the JSON Schema (draft 7) of machine or scenario files, for yaml-language-server.

    It knows every installed plugin skill and `--skills` folder: save it
    (`orchestrator schema machine --skills my_skills > machine.schema.json`) and point the
    editor at it with `# yaml-language-server: $schema=machine.schema.json`."""
    from ..language.schema_gen import schema_text

    if kind not in ("machine", "scenario"):
        err.print(f"unknown schema {kind[:80]!r} (valid: machine, scenario)", markup=False)
        raise typer.Exit(EXIT_INVALID)
    use_skills(skills)
    sys.stdout.write(schema_text(kind))


LISTS = ("scenarios", "machines", "skills", "checks", "guards", "robots")


def list_(
    what: Annotated[
        str | None,
        typer.Argument(help="scenarios, machines, skills, checks, guards or robots (all)."),
    ] = None,
    skills: SkillPaths = None,
) -> None:
    """Bundled scenarios and machines, available skills and success checks (with plugins),
    guards and robots."""
    from rich.table import Table

    from ..guards import GUARDS
    from ..language.bundled import bundled_names
    from ..language.diagnostics import did_you_mean
    from ..robots import ROBOTS
    from ..skills import all_skills
    from ..skills.plugins import skill_origin
    from ..success import CHECKS, check_origin

    if what is not None and what not in LISTS:
        hint = did_you_mean(what, LISTS)
        err.print(f"unknown list {what!r}{hint} (valid: {', '.join(LISTS)})", markup=False)
        raise typer.Exit(EXIT_INVALID)
    use_skills(skills)
    show = LISTS if what is None else (what,)
    if "scenarios" in show:
        out.print("[bold]scenarios[/]: " + escape(", ".join(bundled_names("scenarios"))))
    if "machines" in show:
        out.print("[bold]machines[/]:  " + escape(", ".join(bundled_names("machines"))))
    if "skills" in show:
        table = Table("skill", "outcomes", "description", box=None, pad_edge=False)
        skills_by_name = all_skills()
        for name in sorted(skills_by_name):
            cls = skills_by_name[name]
            origin = skill_origin(cls)
            doc = _first_sentence(cls) + ("" if origin == "bundled" else f" ({origin})")
            table.add_row(escape(name), escape(", ".join(cls.outcomes)), escape(doc))
        out.print(table)
        out.print("`orchestrator show skill NAME`: parameters with types, units and defaults.")
    if "checks" in show:
        table = Table("success check", "description", box=None, pad_edge=False)
        for kind in sorted(CHECKS):
            cls = CHECKS[kind]
            origin = check_origin(cls)
            doc = _first_sentence(cls) + ("" if origin == "bundled" else f" ({origin})")
            table.add_row(escape(kind), escape(doc))
        out.print(table)
        out.print(
            "`orchestrator show check KIND`: its parameters; a scenario's `success:` uses it."
        )
    if "guards" in show:
        out.print("[bold]guards[/]:    " + escape(", ".join(sorted(GUARDS))))
    if "robots" in show:
        out.print("[bold]robots[/]:    " + escape(", ".join(sorted(ROBOTS))))
    if what is None:
        from ..perception.backends import backend_status

        out.print("[bold]camera renderer[/]: " + escape(backend_status().describe()))


def _first_sentence(cls: type) -> str:
    text = " ".join((cls.__doc__ or "").split())
    return text.split(". ")[0].rstrip(".") + "." if text else ""


SHOWS = ("skill", "check", "guard", "scenario", "machine", "robot")


def show(
    kind: Annotated[str, typer.Argument(help="skill, check, guard, scenario, machine or robot")],
    name: Annotated[str, typer.Argument(help="Its name (a scenario or machine: or a file).")],
    skills: SkillPaths = None,
) -> None:
    """Describe one skill, success check or guard (parameters: type, unit, default, range;
    outcomes; blackboard writes), one scenario (scene, the blackboard values it uses and
    --set takes, success checks), one machine (its graph in Mermaid) or one robot (its
    joints, limits and gripper)."""
    from ..guards import GUARDS
    from ..language import reference
    from ..language.diagnostics import did_you_mean
    from ..skills import all_skills
    from ..success import CHECKS

    if kind not in SHOWS:
        hint = did_you_mean(kind, SHOWS)
        err.print(f"unknown kind {kind!r}{hint} (valid: {', '.join(SHOWS)})", markup=False)
        raise typer.Exit(EXIT_INVALID)
    use_skills(skills)
    if kind in ("skill", "check", "guard", "robot"):
        from ..robots import ROBOTS
        from ..robots.describe import robot_markdown

        tables = {"skill": all_skills(), "check": CHECKS, "guard": GUARDS, "robot": ROBOTS}
        table: dict = tables[kind]
        if name not in table:
            hint = did_you_mean(name, table)
            valid = ", ".join(sorted(table))
            err.print(f"unknown {kind} {name!r}{hint} (valid: {valid})", markup=False)
            raise typer.Exit(EXIT_INVALID)
        page = {
            "skill": reference.skill_markdown,
            "check": reference.check_markdown,
            "guard": reference.guard_markdown,
            "robot": robot_markdown,
        }[kind](table[name], level=1)
    elif kind == "scenario":
        from ..language.load import load_scenario

        try:
            page = reference.scenario_summary(load_scenario(name, import_skills=False))
        except ConfigError as exc:
            fail_config(exc, "nothing to show")
            return
    else:
        graph(name, "mermaid", None)
        return
    _print_markdown(page)


def _print_markdown(page: str) -> None:
    if out.is_terminal:
        from rich.markdown import Markdown

        out.print(Markdown(page))
    else:
        sys.stdout.write(page)
