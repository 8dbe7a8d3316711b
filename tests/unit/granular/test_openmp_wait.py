"""GNU OpenMP's barrier waiting for a granular run: brief spinning only where every thread has an idle core,
passive waiting otherwise, and a user's own setting untouched (``numba_config.openmp_wait_for_idle_cores``)."""

import os

import numba
import pytest

from porepipe._shared import numba_config

_VARS = ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT")
_MANY = numba.config.NUMBA_NUM_THREADS


@pytest.fixture
def clean_env(monkeypatch):
    for name in _VARS:
        monkeypatch.delenv(name, raising=False)
    return monkeypatch


@pytest.mark.skipif(_MANY < 2, reason="needs numba to allow 2 threads")
def test_idle_cores_for_every_thread_spin_briefly(clean_env):
    clean_env.setattr(numba_config, "idle_cores", lambda: float(_MANY))
    assert numba_config.openmp_wait_for_idle_cores(None) == f"spin {numba_config.IDLE_SPINCOUNT}"
    assert os.environ["GOMP_SPINCOUNT"] == str(numba_config.IDLE_SPINCOUNT)
    assert "OMP_WAIT_POLICY" not in os.environ


@pytest.mark.skipif(_MANY < 2, reason="needs numba to allow 2 threads")
def test_a_busy_core_means_passive_waiting(clean_env):
    clean_env.setattr(numba_config, "idle_cores", lambda: _MANY - 1.0)
    assert numba_config.openmp_wait_for_idle_cores(_MANY) == "passive"
    assert os.environ["OMP_WAIT_POLICY"] == "PASSIVE"
    assert "GOMP_SPINCOUNT" not in os.environ


def test_one_thread_waits_passively_without_sampling(clean_env):
    def sampled():
        raise AssertionError("one thread has no barrier to wait at; the load need not be sampled")

    clean_env.setattr(numba_config, "idle_cores", sampled)
    assert numba_config.openmp_wait_for_idle_cores(1) == "passive"


def test_unknown_idle_cores_mean_passive_waiting(clean_env):
    clean_env.setattr(numba_config, "idle_cores", lambda: None)
    assert numba_config.openmp_wait_for_idle_cores(2) == "passive"


@pytest.mark.parametrize("name,value", [("OMP_WAIT_POLICY", "ACTIVE"), ("GOMP_SPINCOUNT", "100")])
def test_a_users_setting_is_kept(clean_env, name, value):
    clean_env.setenv(name, value)
    clean_env.setattr(numba_config, "idle_cores", lambda: float(_MANY))
    assert numba_config.openmp_wait_for_idle_cores(2) == "user"
    assert os.environ[name] == value
    assert all(other not in os.environ for other in _VARS if other != name)


@pytest.mark.skipif(not os.path.exists("/proc/stat"), reason="idle cores are read from /proc/stat")
def test_idle_cores_lie_between_none_and_all():
    free = numba_config.idle_cores(0.05)
    assert free is not None and 0.0 <= free <= os.cpu_count() + 1e-9
