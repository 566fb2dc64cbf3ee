"""Random numbers for page 4: seeded numpy Generators, one stream per image row.

The original draws ``rand()`` in program order; that sequence cannot be reproduced (it is
glibc's or MSVC's), only its distribution (facts.md F15). The port gives every ray a fixed block of
DRAWS uniforms in [0, 1): index 0, 1 = the lens offsets u1, u2 (facts.md F5), index 2 + k = the
roulette draw of segment k (k = 0..9). A slot a ray does not need is skipped, not shifted, so
strict and clean use the same numbers for the same events.

Streams (``numpy.random.PCG64`` seeded by ``SeedSequence(seed, spawn_key=...)``; one double
per 64-bit output):

* auto exposure: key (0,), ``random((16, 16, DRAWS))`` indexed [j (probe row), i, draw];
* image row y: key (1, y); repeat c (0 <= c < Complexity) takes the c-th block of
  W * 2 * 2 * DRAWS numbers, shaped (W, 2, 2, DRAWS) and indexed [x, a, b, draw] for
  sub-sample (x + a/2, y + b/2). A block is reached with ``PCG64.advance``.

So a pixel's value depends only on the seed and the pixel, not on tiling, worker count,
rendered sub-rectangle or stride.
"""

from __future__ import annotations

import numpy as np

DRAWS = 12


def _bit_generator(seed: int, *key: int) -> np.random.PCG64:
    return np.random.PCG64(np.random.SeedSequence(seed, spawn_key=key))


def probe_draws(seed: int, grid: int = 16) -> np.ndarray:
    return np.random.Generator(_bit_generator(seed, 0)).random((grid, grid, DRAWS))


def row_draws(seed: int, y: int, first: int, stop: int, width: int) -> np.ndarray:
    """Draws of repeats first..stop-1 of image row y: (stop - first, width, 2, 2, DRAWS)."""
    bits = _bit_generator(seed, 1, y)
    block = width * 4 * DRAWS
    if first:
        bits.advance(first * block)
    return np.random.Generator(bits).random((stop - first, width, 2, 2, DRAWS))
