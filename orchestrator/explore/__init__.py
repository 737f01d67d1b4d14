"""Explore a scenario's declared space: variations, invariants, shrunk counterexamples.

The modules are imported by name (`orchestrator.explore.campaign`, `.params`, `.sampler`,
`.shrink`), inside the command (orchestrator/cli/explore.py) that the command line registers
at start-up: importing this package must not load the physics (tests/test_startup.py).
"""
