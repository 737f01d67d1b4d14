"""A file's parsed YAML is kept per process by its text: edits are seen, copies handed out."""

from __future__ import annotations

from pathlib import Path

import pytest

from orchestrator.exceptions import ConfigError
from orchestrator.language import yamlio
from orchestrator.language.load import load_scenario
from orchestrator.language.yamlio import load_yaml


def test_each_load_gets_its_own_copy_of_the_data_and_positions(tmp_path: Path):
    path = tmp_path / "m.yaml"
    path.write_text("name: m\nstates:\n  A: {skill: wait}\n")
    first = load_yaml(path)
    first.data["states"]["A"]["skill"] = "changed"
    first.source.marks.clear()
    second = load_yaml(path)
    assert second.data == {"name": "m", "states": {"A": {"skill": "wait"}}}
    assert second.source.locate(("states", "A")) == (3, 3)


def test_an_edited_file_is_read_anew(tmp_path: Path):
    path = tmp_path / "m.yaml"
    path.write_text("name: a\n")
    assert load_yaml(path).data == {"name": "a"}
    path.write_text("name: b\n")
    assert load_yaml(path).data == {"name": "b"}
    path.write_text("name: [b\n")
    with pytest.raises(ConfigError) as err:
        load_yaml(path)
    assert err.value.diagnostics[0].line == 1


def test_a_refused_text_is_refused_every_time(tmp_path: Path):
    path = tmp_path / "m.yaml"
    path.write_text("a: !!python/object:os.system x\n")
    for _ in range(2):
        with pytest.raises(ConfigError):
            load_yaml(path)


def test_the_same_text_is_parsed_once(tmp_path: Path, monkeypatch):
    path = tmp_path / "m.yaml"
    path.write_text("name: once\nvalue: 1\n")
    parsed: list[str] = []
    real = yamlio.parse_yaml

    def counting(text: str, file: str, limits=None):
        parsed.append(file)
        return real(text, file, limits)

    monkeypatch.setattr(yamlio, "parse_yaml", counting)
    docs = [load_yaml(path) for _ in range(3)]
    assert parsed == [str(path)]
    assert all(d.data == {"name": "once", "value": 1} for d in docs)


def test_a_scenario_loaded_twice_with_different_settings_keeps_them_apart():
    moved = load_scenario("pick_place", ["scene.objects.0.xy=[0.45, 0.05]"])
    plain = load_scenario("pick_place")
    again = load_scenario("pick_place", ["scene.objects.0.xy=[0.45, 0.05]"])
    assert moved.scenario.scene.objects[0].xy == again.scenario.scene.objects[0].xy
    assert plain.scenario.scene.objects[0].xy != moved.scenario.scene.objects[0].xy
    assert plain.scenario == load_scenario("pick_place").scenario
