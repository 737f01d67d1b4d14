"""Explore a scenario's declared space: variations, invariants, shrunk counterexamples."""

from .campaign import ExploreConfig, explore, load_space
from .params import Parameter, scenario_parameters
from .sampler import Variation, draw_variations
from .shrink import Shrunk, shrink

__all__ = [
    "ExploreConfig",
    "Parameter",
    "Shrunk",
    "Variation",
    "draw_variations",
    "explore",
    "load_space",
    "scenario_parameters",
    "shrink",
]
