"""Progress: the ETA follows the convergence rate (exact for an exponential residual and for a 1/√n Monte Carlo
error), compile time is kept out of the rate and shown apart, lines are sparse off a terminal, and a job under
`porepipe run` also writes to the console file it was given."""

import io
import math

import pytest

from porepipe._shared import progress as P


class Clock:
    def __init__(self):
        self.t = 100.0

    def __call__(self):
        return self.t


@pytest.fixture
def clock(monkeypatch):
    c = Clock()
    monkeypatch.setattr(P.time, "perf_counter", c)
    monkeypatch.delenv(P.CONSOLE_ENV, raising=False)
    return c


def test_exponential_residual_gives_the_exact_time_to_target(clock):
    tau, target = 7.0, 1e-6
    bar = P.Progress("lbm", total=10**6, stream=io.StringIO(), target=target)
    for step in range(1, 6):
        clock.t += 3.0
        bar.update(step, residual=math.exp(-(clock.t - 100.0) / tau))
    # r(t) = exp(-t/τ) reaches the target after τ ln(1/target); 15 s have passed
    assert bar.eta_s() == pytest.approx(tau * math.log(1 / target) - 15.0, rel=1e-9)


def test_statistical_error_gives_the_inverse_square_law(clock):
    bar = P.Progress("mc", stream=io.StringIO(), target=0.01, convergence="statistical")
    clock.t += 20.0
    bar.update(4, residual=0.04)  # error ∝ 1/√t: 4× too large needs 16× the time, 15× more
    assert bar.eta_s() == pytest.approx(20.0 * 15.0)


def test_no_eta_while_the_residual_does_not_fall(clock):
    bar = P.Progress("x", stream=io.StringIO(), target=1e-3)
    for r in (1.0, 1.0, 2.0):
        clock.t += 1.0
        bar.update(1, residual=r)
    assert bar.eta_s() is None


def test_compile_time_is_kept_out_of_the_rate_and_named_in_the_closing_line(clock, monkeypatch):
    out = io.StringIO()
    bar = P.Progress("pack", total=100, stream=out)
    clock.t += 50.0
    monkeypatch.setitem(
        P._compile, "seconds", P._compile["seconds"] + 40.0
    )  # 40 of the 50 s compiled kernels
    bar.update(10)
    assert bar.compute_s() == pytest.approx(10.0)
    assert bar.eta_s() == pytest.approx(90.0)  # 10 steps per 10 s of computing, 90 steps to go
    bar.close("converged after 10 steps, 3 deleted")
    last = out.getvalue().strip().splitlines()[-1]
    assert last == "[pack] done in 10 s + 40 s compiling kernels: converged after 10 steps, 3 deleted"


def test_lines_are_sparse_off_a_terminal_and_copied_to_the_console_of_porepipe_run(
    clock, monkeypatch, tmp_path
):
    console = tmp_path / "tty"
    # under CI the console copy is off by design; this test is about the copy itself
    monkeypatch.delenv("CI", raising=False)
    monkeypatch.setenv(P.CONSOLE_ENV, str(console))
    monkeypatch.setattr(P, "_console_stream", None)
    log = io.StringIO()
    bar = P.Progress("lbm z", total=1000, stream=log, every_s=5.0)
    for step in range(1, 61):  # one update per second for a minute
        clock.t += 1.0
        bar.update(step)
    bar.close("done")
    P._console_stream.close()
    monkeypatch.setattr(P, "_console_stream", None)
    assert len(log.getvalue().splitlines()) == 13  # every 5 s (12) and the closing line
    assert len(console.read_text().splitlines()) == 7  # every 10 s (6) and the closing line


def test_a_real_compilation_is_announced_once_and_timed(capsys):
    import numba

    P.watch_compilation()
    before_s, before_n = P.compile_seconds(), P.compiled_kernels()

    @numba.njit(cache=False)
    def twice(x):
        return 2.0 * x

    assert twice(1.5) == 3.0
    assert P.compiled_kernels() == before_n + 1 and P.compile_seconds() > before_s
    twice(2.5)  # already compiled: no new compile
    assert P.compiled_kernels() == before_n + 1
    err = capsys.readouterr().err
    assert err.count("compiling kernels (first run only") <= 1
