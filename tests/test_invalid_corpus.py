"""A corpus of invalid machines and scenarios: each is reported at the exact file:line, with
the expected message, exit code 2, no traceback and no pydantic URL; the JSON Schema rejects
the ones that are schema-level mistakes and accepts every bundled file.

A case's header: `# expect: LINE: fragment`, `# schema: reject|accept|skip`, and optionally
`# run: ARGS` — then it is `orchestrator run FILE ARGS` (a bad `--set` value), refused before
anything moves: the message names FILE:LINE of the parameter that cannot take the value."""

from __future__ import annotations

import json
import re
import shlex
from pathlib import Path

import jsonschema
import pytest
import yaml

from orchestrator.language.bundled import bundled_path
from orchestrator.language.schema_gen import SCHEMA_DIR

CORPUS = Path(__file__).parent / "corpus"
FILES = sorted(CORPUS.glob("*.yaml"))
REPO = Path(__file__).resolve().parent.parent


def _header(path: Path) -> tuple[int, str, str]:
    lines = path.read_text().splitlines()
    m = re.match(r"# expect: (\d+): (.*)$", lines[0])
    s = re.match(r"# schema: (reject|accept|skip)$", lines[1])
    assert m and s, f"{path.name}: needs '# expect: LINE: fragment' and '# schema: ...' headers"
    return int(m.group(1)), m.group(2), s.group(1)


def _run_args(path: Path) -> list[str] | None:
    """The `# run: ARGS` of a case answered by `run` rather than `validate`."""
    third = path.read_text().splitlines()[2]
    return shlex.split(third.removeprefix("# run: ")) if third.startswith("# run: ") else None


def test_the_corpus_has_at_least_25_cases():
    assert len(FILES) >= 25


@pytest.mark.parametrize("path", FILES, ids=lambda p: p.stem)
def test_invalid_file_is_reported_at_its_line(cli, path):
    line, fragment, _ = _header(path)
    args = _run_args(path)
    res = cli("validate", str(path)) if args is None else cli("run", str(path), *args)
    assert res.exit_code == 2, res.stdout
    assert res.exception is None and "Traceback" not in res.stderr
    assert "pydantic" not in res.stderr  # neither its URLs nor its class names
    if args is None:
        located = [ln for ln in res.stderr.splitlines() if ln.startswith(f"{path}:{line}:")]
    else:  # the value is the command line's; the message points at the parameter
        located = [ln for ln in res.stderr.splitlines() if f"({path}:{line})" in ln]
        assert "nothing was simulated" in res.stderr and not res.stdout
    assert any(fragment in ln for ln in located), res.stderr


def _schema(kind: str) -> jsonschema.Draft7Validator:
    return jsonschema.Draft7Validator(json.loads((SCHEMA_DIR / f"{kind}.schema.json").read_text()))


@pytest.mark.parametrize(
    "path", [p for p in FILES if _header(p)[2] != "skip"], ids=lambda p: p.stem
)
def test_schema_rejects_exactly_the_schema_level_mistakes(path):
    _, _, verdict = _header(path)
    data = yaml.safe_load(path.read_text())
    kind = "scenario" if path.name.startswith("s_") else "machine"
    errors = list(_schema(kind).iter_errors(data))
    if verdict == "reject":
        assert errors, f"{path.name}: the schema accepted a schema-level mistake"
    else:
        assert not errors, [e.message for e in errors]


def _bundled() -> list[tuple[str, Path]]:
    from orchestrator.language.bundled import bundled_names

    out = []
    for kind in ("machines", "scenarios"):
        for name in bundled_names(kind):
            path = bundled_path(kind, name)
            assert path is not None
            out.append((kind[:-1], path))
    return out


@pytest.mark.parametrize(("kind", "path"), _bundled(), ids=lambda v: getattr(v, "stem", v))
def test_schema_accepts_every_bundled_file_and_it_has_the_modeline(kind, path):
    text = path.read_text()
    assert text.startswith(
        f"# yaml-language-server: $schema=../orchestrator/schemas/{kind}.schema.json"
    )
    errors = list(_schema(kind).iter_errors(yaml.safe_load(text)))
    assert not errors, [e.message for e in errors]


@pytest.mark.parametrize("kind", ["machine", "scenario"])
def test_generated_schemas_are_not_stale(kind):
    from orchestrator.language.schema_gen import schema_text

    on_disk = (SCHEMA_DIR / f"{kind}.schema.json").read_text()
    assert on_disk == schema_text(kind, bundled_only=True), (
        "orchestrator/schemas is stale: run `python -m orchestrator.language.schema_gen`"
    )


@pytest.mark.parametrize("kind", ["machine", "scenario"])
def test_schema_command_prints_a_draft7_schema(cli, kind):
    res = cli("schema", kind)
    assert res.exit_code == 0
    schema = json.loads(res.stdout)
    assert schema["$schema"] == "http://json-schema.org/draft-07/schema#"
    jsonschema.Draft7Validator.check_schema(schema)


def test_a_misspelled_state_is_one_error_not_a_cascade(cli):
    # PLAC for PLACE leaves PLACE, RETREAT, HOME and DONE unreached: only the root cause is said
    res = cli("validate", str(CORPUS / "m_misspelled_state.yaml"))
    assert res.exit_code == 2
    errors = [ln for ln in res.stderr.splitlines() if "m_misspelled_state.yaml:" in ln]
    assert len(errors) == 1, res.stderr
    assert "did you mean 'PLACE'?" in errors[0]


def test_one_mistake_repeated_is_said_once_with_a_count(cli):
    # deleting FAILED strands four transitions: one line, the count, the other lines
    res = cli("validate", str(CORPUS / "m_deleted_state.yaml"))
    assert res.exit_code == 2
    errors = [ln for ln in res.stderr.splitlines() if "m_deleted_state.yaml:" in ln]
    assert len(errors) == 1, res.stderr
    assert res.stderr.splitlines()[-1] == "1 error; nothing was simulated."


def test_validate_a_folder_checks_every_yaml_in_it(cli):
    res = cli("validate", str(REPO / "machines"))
    assert res.exit_code == 0, res.stderr
    assert [ln.split()[-1] for ln in res.stdout.splitlines()] == [
        str(p) for p in sorted((REPO / "machines").glob("*.yaml"))
    ]


def test_a_missing_file_is_not_located_at_0_0(cli):
    res = cli("validate", "no_such_file.yaml")
    assert res.exit_code == 2
    assert res.stderr.startswith("no_such_file.yaml: <file>: no such file"), res.stderr
