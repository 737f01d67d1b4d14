"""The bundled skills' index: each name found by importing only its own module.

`orchestrator.skills.registry.BUNDLED` (name -> module) lets validation import just the modules
of the skills a machine uses. It must say what importing every module of the package finds, or
a new skill would be found only by the slow path (and `skill_names` would not list it).
"""

from __future__ import annotations

import json
import subprocess
import sys

from orchestrator.skills import all_skills, bundled_skill_names
from orchestrator.skills.registry import BUNDLED


def test_the_index_names_every_bundled_skill_and_its_module():
    skills = all_skills()
    found = {name: skills[name].__module__.rsplit(".", 1)[1] for name in bundled_skill_names()}
    missing = {n: m for n, m in found.items() if BUNDLED.get(n) != m}
    assert missing == {}, (
        f"add these to BUNDLED in skills/registry.py (skill name -> module): {missing}"
    )
    assert set(BUNDLED) == set(found), f"BUNDLED names no skill: {set(BUNDLED) - set(found)}"


PROBE = """\
import json, sys
from orchestrator.skills import find_skill, get_skill, skill_names
before = {m for m in sys.modules if m.startswith("orchestrator.skills.")}
names = skill_names()
listed = {m for m in sys.modules if m.startswith("orchestrator.skills.")} - before
cls = find_skill("pass_parcel")
after = {m for m in sys.modules if m.startswith("orchestrator.skills.")} - before
other = get_skill("wait_for_parcel").__module__
missing = find_skill("no_such_skill")
everything = {m for m in sys.modules if m.startswith("orchestrator.skills.")} - before
print(json.dumps({
    "names": names, "listed": sorted(listed), "found": cls.__module__, "after": sorted(after),
    "other": other, "missing": missing, "everything": len(everything),
}))
"""


def test_a_skill_is_found_by_importing_its_module_only():
    proc = subprocess.run(
        [sys.executable, "-c", PROBE], capture_output=True, text=True, check=True, timeout=60
    )
    got = json.loads(proc.stdout)
    assert got["names"] == sorted(BUNDLED)  # listing the names imports no skill module
    assert got["listed"] == []
    assert got["found"] == "orchestrator.skills.conveyor"
    assert got["after"] == ["orchestrator.skills.conveyor"]  # (and what conveyor imports)
    assert got["other"] == "orchestrator.skills.conveyor"  # the second skill of that module
    # an unknown name is looked for everywhere before it is called unknown
    assert got["missing"] is None
    assert got["everything"] > 20
