"""A packing run compiles each kernel once, in the variant it needs: a small pack on one thread compiles only the
serial kernels (about half the compile time of the parallel ones), one signature each; a
read-only ``periodic`` array passed by a caller compiles nothing more (it used to compile every kernel twice); the
half-list scan shared by counting and filling compiles once."""

import os
import subprocess
import sys

import numba
import numpy as np

from porepipe._shared.numba_config import ByThreads, by_threads

# in a fresh interpreter, so that no other test's calls add signatures; `per` is read-only on purpose
_SCRIPT = """
import numba, numpy as np
from porepipe.packing import Settings, pack_spheres, sphere_overlaps
from porepipe.packing import _kernels as K
from porepipe._shared.numba_config import ByThreads
numba.set_num_threads(1)
types = [{"name": "g", "count": 40, "max_overlap": 0.3, "radius_um": {"min_um": 6, "max_um": 10}}]
stage = {"name": "p", "insert": ["g"], "steps": 40, "dt": 0.05, "k": {"g": 400}, "damping": {"g": 4},
         "freezing": {"lock_step": 10}, "stochastic_forces": {"step_size": 0.05}}
settings = Settings.model_validate({"types": types, "stages": [stage]})
p = pack_spheres(settings, np.full(3, 60.0), True, seed=1)
per = np.broadcast_to(np.array(True), (3,))
sphere_overlaps(p.centres_um, p.radii_um, p.types, np.full(3, 60.0), per, [0.3])
kernels = {n: k for n, k in vars(K).items() if isinstance(k, ByThreads)}
kernels.update({"step_" + "".join(str(int(f)) for f in key): k for key, k in K._STEP_CACHE.items()})
for name, k in sorted(kernels.items()):
    print(name, len(k.serial.signatures), len(k.parallel.signatures))
"""


def test_a_one_thread_pack_compiles_each_serial_kernel_once():
    out = subprocess.run([sys.executable, "-c", _SCRIPT], capture_output=True, text=True, check=True)
    counts = {line.split()[0]: tuple(map(int, line.split()[1:])) for line in out.stdout.splitlines()}
    assert {"_half_counts", "_half_fill", "_step_reductions"} <= counts.keys(), counts
    assert any(name.startswith("step") for name in counts), counts
    assert all(serial <= 1 and parallel == 0 for serial, parallel in counts.values()), counts
    assert counts["_half_counts"] == (1, 0) and counts["_step_reductions"] == (1, 0), counts


_SCAN_SCRIPT = """
import numba, numpy as np
from porepipe.packing import _kernels as K
from porepipe.packing._neighbours import build_neighbours
numba.set_num_threads(1)
x = np.random.default_rng(0).random((40, 3)) * 30.0
one = np.ones((1, 1), dtype=np.bool_)
build_neighbours(x, np.full(40, 2.0), np.zeros(40, dtype=np.int64), np.full(3, 30.0), (True,) * 3, one, 1.0, 0.5)
print(len(K._scan_half.signatures))
"""


def test_counting_and_filling_the_half_list_share_one_compiled_scan(tmp_path):
    # a fresh numba cache, so the scan is compiled here rather than skipped behind its callers' cached code; a
    # literal True/False ``write`` flag used to compile it once per value
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}
    out = subprocess.run(
        [sys.executable, "-c", _SCAN_SCRIPT], capture_output=True, text=True, check=True, env=env
    )
    assert out.stdout.split() == ["1"], out.stdout


@by_threads(cache=False)
def _chunk_sums(x, out):
    for c in numba.prange(out.size):  # fixed chunks: the same sums for any thread count
        s = 0.0
        for i in range(c * x.size // out.size, (c + 1) * x.size // out.size):
            s += x[i]
        out[c] = s


def test_both_variants_give_the_same_bits_and_are_picked_by_the_thread_count():
    x = np.random.default_rng(0).random(1000)
    ref = np.add.reduceat(x, np.arange(0, 1000, 125))  # numpy's pairwise sums of 8 chunks: to round-off only
    got = {}
    for variant in ("serial", "parallel"):
        out = np.empty(8)
        getattr(_chunk_sums, variant)(x, out)
        got[variant] = out
    assert got["serial"].tobytes() == got["parallel"].tobytes()
    np.testing.assert_allclose(got["serial"], ref, rtol=1e-14)
    assert isinstance(_chunk_sums, ByThreads)
    before = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        _chunk_sums(x, np.empty(8))
        assert len(_chunk_sums.serial.signatures) == 1
        big = np.zeros(_chunk_sums.serial_max_elements + 1)  # a large call runs the faster parallel code
        assert _chunk_sums.pick(big, np.empty(8)) is _chunk_sums.parallel
    finally:
        numba.set_num_threads(before)
