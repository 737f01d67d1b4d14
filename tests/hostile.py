"""Generators of hostile machine and scenario files: one function per class of input that
once broke the tool (issue 10, part 3). Each returns a `Hostile`: the files to write, the one
to hand to the command, and the line the answer must point at (0: any real line)."""

from __future__ import annotations

import random
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
SCENARIO_HEAD = "name: s\nmachine: m.yaml\n"
MACHINE_HEAD = "name: m\ninitial: A\n"


@dataclass
class Hostile:
    """One hostile input.

    Attributes:
        name: What it is.
        files: Relative path -> content (bytes or text) to write into a fresh directory.
        entry: The file given to the command.
        line: The line the first message must name (0: any line >= 1).
        fragment: Text the messages must contain ("" to skip).
    """

    name: str
    files: dict[str, bytes | str]
    entry: str = "m.yaml"
    line: int = 0
    fragment: str = ""
    extra: dict[str, str] = field(default_factory=dict)
    links: dict[str, str] = field(default_factory=dict)
    """Relative path -> where the symlink written there points (relative to it)."""

    def write(self, root: Path) -> Path:
        for rel, content in self.files.items():
            path = root / rel
            path.parent.mkdir(parents=True, exist_ok=True)
            if isinstance(content, str):
                path.write_text(content)
            else:
                path.write_bytes(content)
        for rel, target in self.links.items():
            (root / rel).parent.mkdir(parents=True, exist_ok=True)
            (root / rel).symlink_to(target)
        return root / self.entry


def _machine(states: str, extra: str = "") -> str:
    return MACHINE_HEAD + extra + "states:\n" + states


OK_STATES = (
    "  A: {skill: hold, with: {duration_s: 0.1}, transitions: {held: B}}\n  B: {final: ok}\n"
)


def deep_flow_list(depth: int = 700) -> Hostile:
    return Hostile(
        f"flow list {depth} deep",
        {"m.yaml": "blackboard: {x: " + "[" * depth + "]" * depth + "}\n"},
    )


def deep_block_mapping(depth: int = 600) -> Hostile:
    lines = "".join("  " * i + f"k{i}:\n" for i in range(depth))
    return Hostile(f"block mapping {depth} deep", {"m.yaml": "blackboard:\n" + lines})


def deep_inline_states(depth: int = 300) -> Hostile:
    text, indent = MACHINE_HEAD + "states:\n", "  "
    for _ in range(depth):
        text += f"{indent}A:\n{indent}  initial: A\n{indent}  transitions: {{ok: B}}\n"
        text += f"{indent}  states:\n"
        indent += "    "
    text += f"{indent}A: {{final: ok}}\n"
    return Hostile(f"inline states {depth} deep", {"m.yaml": text})


def include_chain(n: int = 400) -> Hostile:
    files: dict[str, bytes | str] = {}
    for i in range(n):
        files[f"m{i}.yaml" if i else "m.yaml"] = _machine(
            f"  A: {{machine: m{i + 1}.yaml, transitions: {{ok: B}}}}\n  B: {{final: ok}}\n"
        )
    files[f"m{n}.yaml"] = _machine("  A: {final: ok}\n")
    return Hostile(f"include chain of {n} files", files, fragment="nest deeper")


def diamond_includes(levels: int = 21) -> Hostile:
    files: dict[str, bytes | str] = {}
    for i in range(levels):
        name = f"d{i}.yaml" if i else "m.yaml"
        nxt = f"d{i + 1}.yaml"
        files[name] = _machine(
            f"  A: {{machine: {nxt}, transitions: {{ok: B}}}}\n"
            f"  B: {{machine: {nxt}, transitions: {{ok: C}}}}\n  C: {{final: ok}}\n"
        )
    files[f"d{levels}.yaml"] = _machine("  A: {final: ok}\n")
    return Hostile(f"diamond includes, 2^{levels} paths", files)


def chained_states(n: int = 9_000) -> Hostile:
    lines = "".join(f"  S{i}: {{skill: hold, transitions: {{held: S{i + 1}}}}}\n" for i in range(n))
    text = "name: m\ninitial: S0\nstates:\n" + lines + f"  S{n}: {{final: ok}}\n"
    return Hostile(f"{n} chained states", {"m.yaml": text})


def recursive_anchor() -> Hostile:
    return Hostile("recursive anchor", {"m.yaml": "name: m\nfoo: &a [*a]\n"}, line=2)


def recursive_merge() -> Hostile:
    return Hostile("recursive merge", {"m.yaml": "name: m\nfoo: &a {<<: *a}\n"}, line=2)


def billion_laughs(levels: int = 9) -> Hostile:
    text = 'name: m\na0: &a0 ["lol","lol","lol","lol","lol","lol","lol","lol","lol","lol"]\n'
    for i in range(1, levels):
        refs = ",".join([f"*a{i - 1}"] * 10)
        text += f"a{i}: &a{i} [{refs}]\n"
    return Hostile("billion laughs", {"m.yaml": text}, fragment="max_nodes")


def merge_chain(levels: int = 40) -> Hostile:
    text = "name: m\nm0: &m0 {k: 1}\n"
    for i in range(1, levels):
        text += f"m{i}: &m{i} {{<<: [*m{i - 1}, *m{i - 1}], k{i}: 1}}\n"
    return Hostile("merge-key chain", {"m.yaml": text}, fragment="max_nodes")


def big_string(mb: int = 50) -> Hostile:
    return Hostile(
        f"{mb} MB string", {"m.yaml": b"name: '" + b"x" * (mb << 20) + b"'\n"}, fragment="bytes"
    )


def bad_scalar(tagged: str, line: int = 4) -> Hostile:
    text = _machine(OK_STATES, f"blackboard:\n  x: {tagged}\n")
    return Hostile(f"scalar {tagged[:20]}", {"m.yaml": text}, line=line)


def huge_int(digits: int = 4400) -> Hostile:
    return bad_scalar("1" * digits)


def unknown_tag(tag: str) -> Hostile:
    return Hostile(
        f"tag {tag}", {"m.yaml": _machine(OK_STATES, f"blackboard:\n  x: {tag}\n")}, line=4,
        fragment="tag",
    )  # fmt: skip


def long_machine_ref(n: int = 5000) -> Hostile:
    text = _machine(
        f"  A: {{machine: {'a' * n}.yaml, transitions: {{ok: B}}}}\n  B: {{final: ok}}\n"
    )
    return Hostile(f"machine: of {n} chars", {"m.yaml": text}, line=4)


def include_escape(ref: str) -> Hostile:
    text = _machine(f"  A: {{machine: {ref}, transitions: {{ok: B}}}}\n  B: {{final: ok}}\n")
    secret = "root: $6$secret-hash-value:19000:0:99999:7:::\nsecret_key: hunter2\n"
    return Hostile(
        f"include {ref}",
        {"proj/m.yaml": text, "secret.yaml": secret},
        entry="proj/m.yaml",
        line=4,
        fragment="outside",
    )


SECRET_SKILL = "hunter2_SECRET_token\n"
"""A module a hostile scenario names as its skills: never imported by `validate`, and quoted by
nothing (importing it would fail with `name 'hunter2_SECRET_token' is not defined`)."""


def skills_escape(entry: str) -> Hostile:
    """A scenario whose `skills:` leaves its tree: an absolute path, `../..`, a symlink out, a
    module that is a symlink out of an in-tree folder."""
    files: dict[str, bytes | str] = {
        "proj/s.yaml": f"name: s\nmachine: pick_place\nskills:\n  - {entry}\n",
        "outside/evil.py": SECRET_SKILL,
    }
    links = {"proj/link": "../outside", "proj/mine/evil.py": "../../outside/evil.py"}
    return Hostile(f"skills: {entry}", files, "proj/s.yaml", 4, "outside", links=links)


def skills_not_a_skill() -> Hostile:
    """In-tree `skills:` naming a module that is no skill: `validate` imports nothing, so the
    machine's skills are checked against the known ones and the file is never read."""
    text = "name: s\nmachine: m.yaml\nskills: [secret.py]\n"
    machine = _machine("  A: {skill: secret_wait, transitions: {done: B}}\n  B: {final: ok}\n")
    return Hostile(
        "skills: a non-skill module",
        {"s.yaml": text, "m.yaml": machine, "secret.py": SECRET_SKILL},
        "s.yaml",
        fragment="pass --skills",
    )


def not_utf8(line: int = 7) -> Hostile:
    body = (_machine(OK_STATES) + "# comment\n" * 10).encode()
    lines = body.split(b"\n")
    lines[line - 1] = lines[line - 1] + b" \xff\xfe"
    return Hostile("not UTF-8", {"m.yaml": b"\n".join(lines)}, line=line, fragment="UTF-8")


def control_char(ch: str, line: int = 5) -> Hostile:
    lines = (_machine(OK_STATES) + "# c\n" * 5).split("\n")
    lines[line - 1] = lines[line - 1] + " # " + ch
    return Hostile(f"control U+{ord(ch):04X}", {"m.yaml": "\n".join(lines)}, line=line)


def error_on_line(n: int = 100) -> Hostile:
    text = _machine(OK_STATES).rstrip("\n") + "\n" + "# pad\n" * (n - 6) + "  C: {skil: hold}\n"
    return Hostile(f"error on line {n}", {"m.yaml": text}, line=n)


def rich_markup_in_names() -> Hostile:
    text = _machine(
        "  A: {skill: '[bold red]:100:[/]', transitions: {held: B}}\n  B: {final: ok}\n"
    )
    return Hostile(
        "rich markup in a value", {"m.yaml": text}, line=4, fragment="[bold red]:100:[/]"
    )


BUNDLED = {
    "machine": (REPO / "machines" / "pick_place.yaml").read_text(),
    "grasp": (REPO / "machines" / "grasp.yaml").read_text(),
    "scenario": (REPO / "scenarios" / "pick_place.yaml")
    .read_text()
    .replace("machine: pick_place", "machine: pick_place.yaml"),
}
FRAGMENTS = [
    "!!python/object/apply:os.system [echo]",
    "!!binary aGk=",
    "!foo x",
    "!!int abc",
    "!!float 1.2.3",
    "!!bool maybe",
    "&a [*a]",
    "*nowhere",
    "1" * 5000,
    ".nan",
    "-.inf",
    "1e999",
    "[" * 200 + "]" * 200,
    "{" * 100,
    "'" + "x" * 3000 + "'",
    "{<<: *x}",
    "\x00",
    "\x1b[31m",
    "\u202e",
    "\ufeff",
    "../../../etc/passwd",
    "/etc/shadow",
    "${HOME}",
    ":100:",
    "[bold]x[/]",
    "- - - -",
    "? complex key",
    "|",
    "%YAML 1.1",
    "--- \n...",
]


def write_bundled(root: Path, which: str, data: bytes) -> Path:
    """Write the bundled pick_place files into `root` with `which` replaced by `data`; return
    the file to validate (the machine for the machines, else the scenario)."""
    names = {"machine": "pick_place.yaml", "grasp": "grasp.yaml", "scenario": "scenario.yaml"}
    for key, name in names.items():
        (root / name).write_text(BUNDLED[key])
    (root / names[which]).write_bytes(data)
    return root / ("pick_place.yaml" if which == "machine" else "scenario.yaml")


def random_mutation(rng: random.Random) -> tuple[str, bytes]:
    """(which bundled file, its bytes) with a hostile fragment spliced into a line (as a value,
    a key, a new line, or raw) or random bytes inserted: the plain-random twin of the
    hypothesis strategy in test_hostile.py, for the campaign in bench/fuzz_campaign.py."""
    which = rng.choice(sorted(BUNDLED))
    lines = BUNDLED[which].splitlines(keepends=True)
    i = rng.randrange(len(lines))
    how = rng.choice(["value", "key", "line", "raw", "bytes"])
    if how == "bytes":
        text = BUNDLED[which].encode()
        at = rng.randrange(len(text) + 1)
        return which, text[:at] + rng.randbytes(rng.randint(1, 8)) + text[at:]
    return which, splice(lines, i, how, rng.choice(FRAGMENTS), rng.randrange(len(lines[i]) + 1))


def splice(lines: list[str], i: int, how: str, frag: str, at: int) -> bytes:
    """`lines` with `frag` put on line `i`: as its value, as a key, on a new line before it, or
    raw at column `at`."""
    lines = list(lines)
    line = lines[i]
    indent = line[: len(line) - len(line.lstrip())]
    if how == "value" and ":" in line:
        lines[i] = f"{line.split(':', 1)[0]}: {frag}\n"
    elif how == "key":
        lines[i] = f"{indent}{frag}: 1\n"
    elif how == "line":
        lines.insert(i, f"{indent}{frag}\n")
    else:
        lines[i] = line[:at] + frag + line[at:]
    return "".join(lines).encode("utf-8", errors="surrogatepass")


PICK_PLACE = (Path(__file__).resolve().parent.parent / "scenarios" / "pick_place.yaml").read_text()


def pick_place_with(old: str, new: str, fragment: str = "") -> Hostile:
    """The bundled pick_place scenario with `old` replaced by `new` (on the line of `old`)."""
    assert old in PICK_PLACE, old
    line = PICK_PLACE[: PICK_PLACE.index(old)].count("\n") + 1
    return Hostile(
        f"pick_place {new}", {"s.yaml": PICK_PLACE.replace(old, new, 1)}, "s.yaml", line, fragment
    )


def absurd_physics() -> list[Hostile]:
    """Values the schema must refuse (each once crashed or hung `run`)."""
    return [
        pick_place_with("size_xy: [0.7, 0.9]", "size_xy: [-0.7, 0.9]"),
        pick_place_with("size: [0.05, 0.05, 0.05]", "size: [1e-300, 0.05, 0.05]"),
        pick_place_with("mass: 0.1", "mass: 1e300"),
        pick_place_with("timestep_s: 0.002", "timestep_s: 1e-300"),
        pick_place_with("control_hz: 100", "control_hz: 1e-6"),
        pick_place_with("time_limit_s: 30", "time_limit_s: 1e300"),
        pick_place_with("height: 0.2", "height: 1e9"),
        pick_place_with("base_pos: [0.0, 0.0, 0.0]", "base_pos: [1e300, 0.0, 0.0]"),
        pick_place_with("xy: [0.5, -0.12]", "xy: [1e6, -0.12]"),
        pick_place_with("max_n: 60", "max_n: 1e308"),
    ]


def final_start_retry() -> Hostile:
    machine = _machine(
        "  A:\n    initial: X\n    retry: 10000\n    retry_on: [bad]\n"
        "    transitions: {bad: B}\n"
        "    states:\n      X: {final: bad}\n  B: {final: succeeded}\n"
    )
    return Hostile(
        "nested machine starting final, retry 100000",
        {"m.yaml": machine, "s.yaml": SCENARIO_HEAD},
        entry="s.yaml",
    )


GENERATORS: list[Callable[[], Hostile | list[Hostile]]] = [
    deep_flow_list,
    deep_block_mapping,
    deep_inline_states,
    include_chain,
    diamond_includes,
    chained_states,
    recursive_anchor,
    recursive_merge,
    billion_laughs,
    merge_chain,
    big_string,
    lambda: bad_scalar("!!int abc"),
    lambda: bad_scalar("!!float abc"),
    lambda: bad_scalar("!!bool maybe"),
    huge_int,
    lambda: unknown_tag("!!python/object/apply:os.system [ls]"),
    lambda: unknown_tag("!!python/object/apply:os.system {a: 1}"),
    lambda: unknown_tag("!foo bar"),
    lambda: unknown_tag("!!binary aGVsbG8="),
    lambda: unknown_tag("!!set {a, b}"),
    long_machine_ref,
    lambda: include_escape("../secret.yaml"),
    lambda: include_escape("/etc/passwd"),
    lambda: skills_escape("../outside"),
    lambda: skills_escape("/etc"),
    lambda: skills_escape("link"),
    lambda: skills_escape("mine"),
    skills_not_a_skill,
    not_utf8,
    lambda: control_char("\x00"),
    lambda: control_char("\x07"),
    lambda: control_char("\x1b"),
    error_on_line,
    rich_markup_in_names,
    absurd_physics,
    final_start_retry,
]


def every_hostile() -> list[Hostile]:
    """One instance of every class."""
    out: list[Hostile] = []
    for gen in GENERATORS:
        made = gen()
        out += made if isinstance(made, list) else [made]
    return out
