"""One seed derivation for every benchmark and mission.

A run is named by the user's seed and a few keys (a map name or index, a trial or run number); its seed
is the first word of ``numpy.random.SeedSequence([seed, *keys])``, text keys entering by their CRC-32.
The same seed and keys give the same run on every executor and in any order; a mission expands its
one seed into three independent ones (start pose, simulator, stack) the same way.

>>> derive_seed(7, "map1", 3) == derive_seed(7, "map1", 3) != derive_seed(8, "map1", 3)
True
>>> len(derive_seeds(0, n=3))
3
"""

from __future__ import annotations

import zlib

import numpy as np

__all__ = ["derive_seed", "derive_seeds"]


def derive_seeds(seed: int, *keys: int | str, n: int = 1) -> tuple[int, ...]:
    """`n` 32-bit seeds for the run named by `seed` and `keys` (ints, or text by its CRC-32)."""
    words = [int(seed), *(zlib.crc32(k.encode("utf-8")) if isinstance(k, str) else int(k) for k in keys)]
    return tuple(int(v) for v in np.random.SeedSequence(words).generate_state(n))


def derive_seed(seed: int, *keys: int | str) -> int:
    """The one 32-bit seed of the run named by `seed` and `keys` (see `derive_seeds`)."""
    return derive_seeds(seed, *keys)[0]
