"""`explore --replay K`: run counterexample K of an exploration again, in this process."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from ..batch.exceptions import BatchError
from ..engine.prepare import prepare
from ..engine.result import RunResult
from .campaign import COUNTEREXAMPLES, MANIFEST
from .verdict import failures

__all__ = ["Replayed", "replay"]


class Replayed:
    """A counterexample run again.

    Attributes:
        example: Its line of `counterexamples.jsonl`.
        result: The run's result.
        failures: What the run shows now (empty: it passes now, e.g. after a fix).
        command: The equivalent `orchestrator run` command.
    """

    def __init__(self, example: dict[str, Any], result: RunResult, ref: str) -> None:
        self.example = example
        self.result = result
        self.failures = failures(result.to_json_dict())
        sets = " ".join(f"--set '{s}'" for s in example["set"])
        self.command = f"orchestrator run {ref} --seed {example['seed']} {sets} --strict".strip()


def replay(out_dir: Path, k: int, scenario: str | None = None,
           allow_paths: tuple[str, ...] = ()) -> Replayed:  # fmt: skip
    """Run counterexample `k` (its variation number) of the exploration in `out_dir`.

    Raises:
        BatchError: No such exploration or counterexample (the message lists the valid K).
        ConfigError: The scenario no longer accepts the variation.
    """
    path = out_dir / COUNTEREXAMPLES
    if not path.is_file():
        raise BatchError(f"{path} does not exist: run `orchestrator explore SCENARIO -n N "
                         f"--out {out_dir}` first")  # fmt: skip
    examples = {}
    for text in path.read_text().splitlines():
        try:
            line = json.loads(text)
        except ValueError:
            continue
        examples[int(line["k"])] = line
    if k not in examples:
        valid = ", ".join(str(x) for x in sorted(examples)) or "none: nothing failed"
        raise BatchError(f"--replay {k}: no counterexample {k} in {path} (valid: {valid})")
    manifest = json.loads((out_dir / MANIFEST).read_text())
    ref = scenario or manifest["scenario_ref"]
    example = examples[k]
    prepared = prepare(ref, example["seed"], example["set"], allow_paths=allow_paths)
    return Replayed(example, prepared.run_episode(), ref)
