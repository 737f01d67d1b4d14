"""The one compiled part: `orchestrator.world._native`, the per-physics-step arithmetic in C.

Optional: without a C compiler (or Python's headers) the build skips it with a warning and the
package runs on its pure-Python twin (orchestrator/world/native.py says which is in use). All
other metadata lives in pyproject.toml.
"""

from setuptools import Extension, setup

setup(
    ext_modules=[
        Extension(
            "orchestrator.world._native",
            ["orchestrator/world/_native.c"],
            # no fused multiply-add: every operation rounds as Python's float arithmetic does,
            # so the compiled and the pure-Python paths agree bit for bit
            extra_compile_args=["-O2", "-ffp-contract=off", "-fno-fast-math"],
            optional=True,
        )
    ]
)
