"""Random streams: every stage derives its own stream from the scene seed and the stage's name.

A stream is ``numpy.random.SeedSequence(entropy=seed, spawn_key=(crc32(stage), *keys))``. The stage name enters as a
spawn-key word, so two stages never share a stream, and the keys (a run index, a particle stream, a sub-sample …)
give independent child streams. Unlike ``SeedSequence([seed, 0])`` versus ``SeedSequence([seed])``, which numpy treats
alike because the entropy is zero-padded, keys of different lengths give different streams.
"""

from __future__ import annotations

import zlib

import numpy as np

__all__ = ["kernel_seed", "seed_sequence", "stream"]


def _stage_word(stage: str) -> int:
    if not isinstance(stage, str) or not stage:
        raise ValueError(f"a random stream needs a stage name (a non-empty string), got {stage!r}")
    return zlib.crc32(stage.encode("utf-8"))


def seed_sequence(seed: int, stage: str, *keys: int) -> np.random.SeedSequence:
    """The seed sequence of ``stage``'s stream ``keys`` under the scene seed ``seed``.

    Parameters
    ----------
    seed : int
        The scene's seed (``seed:`` in the YAML), ≥ 0.
    stage : str
        The stage's name (``"packing"``, ``"diffusion"`` …): different names give independent streams.
    *keys : int
        Further non-negative integers that name a sub-stream (a protocol stage, a batch, a worker).

    Returns
    -------
    numpy.random.SeedSequence
    """
    seed = int(seed)
    if seed < 0:
        raise ValueError(f"seed must be >= 0, got {seed}")
    words = tuple(int(k) for k in keys)
    if any(k < 0 for k in words):
        raise ValueError(f"stream keys must be >= 0, got {keys}")
    return np.random.SeedSequence(entropy=seed, spawn_key=(_stage_word(stage), *words))


def stream(seed: int, stage: str, *keys: int) -> np.random.Generator:
    """A ``numpy.random.Generator`` (PCG64) for ``stage``'s stream ``keys``; see :func:`seed_sequence`."""
    return np.random.default_rng(seed_sequence(seed, stage, *keys))


def kernel_seed(seed: int, stage: str, *keys: int) -> int:
    """A 63-bit integer seed for a numba kernel's own generator, from the same derivation as :func:`stream`."""
    return int(seed_sequence(seed, stage, *keys).generate_state(1, dtype=np.uint64)[0] >> np.uint64(1))
