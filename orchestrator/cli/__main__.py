"""`python -m orchestrator.cli`: the same as the `orchestrator` command."""

from . import main

main()
