"""embodied-orchestrator: declarative YAML state machines for robot task flows, run headless
and deterministic on MuJoCo physics.

One folder per layer (imports only go down; see docs/architecture.md): `language` (the YAML
language), `engine` (running a machine), `world` (the MuJoCo body), `guards`, `recording`,
`batch`; `skills` and `robots` are installed as `orchestrator.skills` and `orchestrator.robots`.
"""

import os as _os

_GL_LIBRARY = {"egl": "EGL", "osmesa": "OSMesa"}
_gl = _os.environ.get("MUJOCO_GL", "").strip().lower()
if _gl in _GL_LIBRARY:
    import ctypes.util as _ctypes_util  # only here: it imports subprocess (~5 ms a command)

    if _ctypes_util.find_library(_GL_LIBRARY[_gl]) is None:
        # `import mujoco` itself fails when MUJOCO_GL names a platform whose library is
        # missing; cameras then use the ray-cast renderer (orchestrator.perception.backends)
        _os.environ["MUJOCO_GL"] = "disable"
        _os.environ["ORCHESTRATOR_GL_MISSING"] = (
            f"MUJOCO_GL={_gl} but lib{_GL_LIBRARY[_gl]} is missing"
        )
