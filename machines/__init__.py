"""Bundled state machines (YAML), found by name."""
