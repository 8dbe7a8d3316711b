"""Random streams from (seed, stage, keys): distinct where they must be, reproducible where they must be."""

import numpy as np
import pytest

from porepipe._shared.rng import kernel_seed, seed_sequence, stream


def test_same_inputs_give_the_same_stream():
    assert np.array_equal(
        stream(7, "packing", 2).integers(0, 2**62, 8), stream(7, "packing", 2).integers(0, 2**62, 8)
    )


@pytest.mark.parametrize(
    "a, b",
    [
        ((7, "packing"), (7, "decorate")),  # stage names separate streams
        ((7, "packing"), (8, "packing")),  # seeds separate streams
        (
            (7, "packing"),
            (7, "packing", 0),
        ),  # a zero key is not the same as no key (SeedSequence pads entropy)
        ((7, "packing", 0), (7, "packing", 0, 0)),
        ((0, "x", 1), (1, "x", 0)),
    ],
)
def test_different_inputs_give_different_streams(a, b):
    assert not np.array_equal(stream(*a).integers(0, 2**62, 4), stream(*b).integers(0, 2**62, 4))
    assert kernel_seed(*a) != kernel_seed(*b)


def test_kernel_seed_fits_a_signed_64_bit_integer():
    assert 0 <= kernel_seed(123, "diffusion", 5) < 2**63


@pytest.mark.parametrize("args", [(-1, "x"), (1, ""), (1, "x", -2)])
def test_bad_inputs_are_refused(args):
    with pytest.raises(ValueError):
        seed_sequence(*args)
