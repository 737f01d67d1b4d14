"""Bundled scenarios (YAML), found by name."""
