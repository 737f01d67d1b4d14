"""embodied-orchestrator: declarative YAML state machines for robot task flows, run headless
and deterministic on MuJoCo physics.

One folder per layer (imports only go down; see docs/architecture.md): `language` (the YAML
language), `engine` (running a machine), `world` (the MuJoCo body), `guards`, `recording`,
`batch`; `skills` and `robots` are installed as `orchestrator.skills` and `orchestrator.robots`.
"""
