"""The scenario a bare machine file runs in (`orchestrator run my_machine.yaml`).

A new user can try a flow before writing any scenario: the machine runs on the Panda at a
table with the scene of the bundled pick-and-place (a 5 cm cube `cube` placed at random and a
pad `pad`), under the guards every bundled scenario uses. There is no success check: the
machine's own final outcome decides. Anything else wants a scenario file
(docs/scenario-reference.md).
"""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

__all__ = ["DEFAULT_SCENARIO", "is_machine_data", "scenario_for_machine"]

DEFAULT_SCENARIO: dict[str, Any] = {
    "robot": {"name": "panda"},
    "scene": {
        "table": {"center_xy": [0.55, 0.0], "size_xy": [0.7, 0.9], "height": 0.2},
        "objects": [
            {
                "name": "cube",
                "size": [0.05, 0.05, 0.05],
                "mass": 0.1,
                "xy": [0.5, -0.12],
                "randomize": {"x": [-0.05, 0.05], "y": [-0.05, 0.05], "yaw_deg": [-30, 30]},
            }
        ],
        "markers": [{"name": "pad", "xy": [0.5, 0.2]}],
    },
    "guards": {
        "workspace": {"min": [0.05, -0.6, 0.15], "max": [0.95, 0.6, 1.2]},
        "contact_force": {"max_n": 60},
        "collision": {},
        "joint_velocity": {},
    },
    "physics": {"time_limit_s": 30},
}
"""Everything but `name` and `machine` of the scenario a bare machine runs in."""


def is_machine_data(data: object) -> bool:
    """True when a parsed YAML document is a machine (states), not a scenario (machine:)."""
    return isinstance(data, dict) and "machine" not in data and ("states" in data)


def scenario_for_machine(machine: dict[str, Any], path: Path) -> dict[str, Any]:
    """The scenario data that runs the machine file at `path` in the default scene."""
    data = copy.deepcopy(DEFAULT_SCENARIO)
    name = machine.get("name")
    data["name"] = name if isinstance(name, str) else path.stem
    data["machine"] = path.name
    return data
