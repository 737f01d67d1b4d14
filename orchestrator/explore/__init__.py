"""Explore a scenario's declared space: variations, invariants, shrunk counterexamples.

The modules are imported by name (`orchestrator.explore.campaign`, `.params`, `.sampler`,
`.shrink`): the command line registers `explore.command` at start-up, and importing this
package must not load the physics (tests/test_startup.py).
"""
