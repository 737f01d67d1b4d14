"""Every random stream of an episode, in one table: name -> tag.

An episode draws from several independent streams, each `numpy.random.default_rng([seed,
tag, *extra])`: the scene's randomization, the sensors' noise, the model mismatch, the
blackboard's goals... Keeping them apart means that adding a draw to one (a new noise term)
leaves every other stream's numbers unchanged, so a scenario's objects land where they did
for the same seed whatever the sensors do.

The tags are the values the streams have always had (changing one changes every result of
that stream: the identity bench would say so). `tests/test_random_streams.py` checks that no
two streams share a tag and that no module of the package makes a generator of its own
outside this table.
"""

from __future__ import annotations

from types import MappingProxyType

import numpy as np

__all__ = ["STREAMS", "stream"]

STREAMS = MappingProxyType({
    "object_poses": 0x5CE4E,       # world/randomization.py: free objects' per-seed offsets
    "phantom_pose": 0xFA27,        # world/randomization.py: the surgical phantom's pose
    "camera_light": 0xCA3E4A,      # world/cameras.py: light intensity and colour
    "camera_noise": 0x1A6E,        # perception/rig.py: image noise
    "conveyor_feed": 0xC07E,       # world/conveyor.py: each fed parcel (with its index)
    "mass_mismatch": 0x3A55,       # world/realism.py: the controller model's link masses
    "wrist_noise": 0xF7,           # world/realism.py: the wrist force sensor's noise
    "encoders": 0xE2C0,            # engine/cell.py: encoder noise
    "skills": 1,                   # engine/cell.py: ctx.rng, the skills' own draws
    "blackboard_goals": 0xB1ACB0A2,  # language/random_goals.py: `randomize: {blackboard: ...}`
    "parcels": 0x9A4C,             # language/parcels.py: the sorting scene's parcels
    "explore": 0xE8B1,             # explore/sampler.py: an exploration's variations
})  # fmt: skip
"""Stream name -> tag (the second word of the generator's seed)."""


def stream(seed: int, name: str, *extra: int) -> np.random.Generator:
    """The generator of stream `name` for episode `seed` (`extra`: a sub-stream, e.g. the
    index of a fed parcel). An unknown name is a KeyError: every stream is in `STREAMS`."""
    return np.random.default_rng([seed, STREAMS[name], *extra])
