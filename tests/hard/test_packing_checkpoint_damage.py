"""A damaged packing checkpoint (not HDF5, empty, truncated, bytes overwritten anywhere) is never resumed from wrongly.

The pack rule always passes ``--checkpoint F --resume``, so a damaged F must neither stop the job (a traceback, or an
error that does not name F, on every rerun) nor feed garbage into the run: ``pack --resume`` says that F cannot be read,
discards it and starts afresh. The independent truth is the uninterrupted run: a resume from an intact checkpoint ends
bit for bit where it ends (tests/unit/packing/test_checkpoint_interval.py), and so does a fresh start, so whatever
happened to F the packing must equal it bit for bit.
"""

from __future__ import annotations

import numpy as np
import pytest

import porepipe.packing._api as engine  # the name the engine calls to save (patched to stop a run mid-way)
from porepipe.packing import Settings, pack_spheres

BOX = np.array([300.0, 300.0, 300.0])
SEED = 5
SPHERE_KEYS = ("centres_um", "radii_um", "types", "max_overlap", "converged")
#: the step whose checkpoint the killed run leaves (of 40; a checkpoint after every step)
KILLED_AT = 17


def _settings() -> Settings:
    """24 spheres of one type, 40 steps without converging, a checkpoint after every step."""
    stage = {"name": "s", "insert": ["a"], "steps": 40, "dt": 0.25, "k": {"a": 400}, "damping": {"a": 4}}
    return Settings.model_validate(
        {
            "types": [
                {"name": "a", "count": 24, "max_overlap": 0.01, "radius_um": {"min_um": 30, "max_um": 50}}
            ],
            "stages": [stage],
            "checkpoint_every": 1,
        }
    )


@pytest.fixture(scope="module")
def reference():
    return pack_spheres(_settings(), BOX, seed=SEED)


@pytest.fixture(scope="module")
def intact_checkpoint(tmp_path_factory) -> bytes:
    """The bytes of the checkpoint a run killed after step KILLED_AT leaves."""
    path = tmp_path_factory.mktemp("killed") / "ck.h5"
    real_save = engine.save_checkpoint

    def save_then_die(path_, state, key, clock):
        real_save(path_, state, key, clock)
        if state.step == KILLED_AT:
            raise KeyboardInterrupt("simulated kill")

    engine.save_checkpoint = save_then_die
    try:
        with pytest.raises(KeyboardInterrupt):
            pack_spheres(_settings(), BOX, seed=SEED, checkpoint_path=path)
    finally:
        engine.save_checkpoint = real_save
    return path.read_bytes()


def _resume(path, reference, capsys) -> str:
    """Resume from ``path``; check the packing against the uninterrupted run; return what it printed to stderr."""
    got = pack_spheres(_settings(), BOX, seed=SEED, checkpoint_path=path, resume=True)
    err = capsys.readouterr().err
    for key in SPHERE_KEYS:
        np.testing.assert_array_equal(getattr(got, key), getattr(reference, key), err_msg=key)  # bit for bit
    assert got.stage_steps == reference.stage_steps
    assert not path.exists()  # a complete run deletes its checkpoint
    return err


def test_an_intact_checkpoint_resumes(tmp_path, capsys, reference, intact_checkpoint):
    path = tmp_path / "ck.h5"
    path.write_bytes(intact_checkpoint)
    assert "discarding" not in _resume(path, reference, capsys)


@pytest.mark.parametrize("damage", ["not HDF5", "empty", "first half", "all but the last byte"])
def test_an_unreadable_checkpoint_is_discarded_saying_why(
    tmp_path, capsys, reference, intact_checkpoint, damage
):
    # before: it was discarded as "written for other settings, box or seed (key none ...)", which it was not
    data = {
        "not HDF5": b"these are not the spheres you are looking for\n",
        "empty": b"",
        "first half": intact_checkpoint[: len(intact_checkpoint) // 2],
        "all but the last byte": intact_checkpoint[:-1],
    }[damage]
    path = tmp_path / "ck.h5"
    path.write_bytes(data)
    err = _resume(path, reference, capsys)
    assert f"checkpoint {path} cannot be read" in err and "discarding it, starting afresh" in err
    assert "other settings" not in err


def test_bytes_overwritten_anywhere_never_change_the_packing_nor_stop_the_run(
    tmp_path, capsys, reference, intact_checkpoint
):
    # before: overwritten bytes in the state arrays were resumed from (a different packing under the same result
    # hash, or "non-finite sphere centres" on every rerun, not naming the checkpoint), and in the file's metadata they
    # raised a raw h5py RuntimeError/OSError traceback. 16 random bytes at 64 places spread over the whole file
    rng = np.random.default_rng(20)
    size = len(intact_checkpoint)
    path = tmp_path / "ck.h5"
    discarded = 0
    for offset in np.linspace(0, size - 16, 64).astype(int):
        data = bytearray(intact_checkpoint)
        data[offset : offset + 16] = rng.integers(0, 256, 16, dtype=np.uint8).tobytes()
        path.write_bytes(bytes(data))
        err = _resume(path, reference, capsys)
        if "discarding" in err:  # the damage was seen: said so, not blamed on other settings
            assert "cannot be read" in err or "it carries no key" in err, (offset, err)
            discarded += 1
    assert discarded > 0  # the damage was seen at least somewhere (else the test checked nothing)
