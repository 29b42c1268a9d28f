"""`simulate(progress=label)` shows one tqdm bar per run that moves over [t0, t1] across all
segments, with few host callbacks, also under vmap (issue 13)."""

import sys

import equinox as eqx
import jax
import jax.numpy as jnp
import pytest

import jaxbearing as jb

simulate_module = sys.modules["jaxbearing.solve._progress"]


_SEEN = []


@pytest.fixture(scope="module", autouse=True)
def _spy():
    """Record the fractions reported to the host. The callback is looked up when the solve is
    traced, and a vmapped call reuses the trace of a single run of the same shapes, so the spy
    is in place before this module's first trace."""
    advance = simulate_module._advance

    def spy(label, fraction, span):
        _SEEN.append(float(fraction))
        advance(label, fraction, span)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(simulate_module, "_advance", spy)
        yield


@pytest.fixture
def reports():
    """The fractions reported to the host during the test."""
    _SEEN.clear()
    return _SEEN


def rotor():
    """A spinning rotor in the paper's bearing: over 0.05 s its balls engage and release about
    50 times (events) in more than 10 segments, a smaller program than the paper's case."""
    return jb.cases.rotor(jb.cases.skf98205(), speed=100.0)


def bars(err, label):
    """The lines of stderr that show ``label``'s bar (tqdm redraws with carriage returns)."""
    return [line for line in err.split("\n") if f"{label}:" in line]


def test_one_bar_per_run_across_segments(capsys, reports):
    sol = jax.block_until_ready(jb.simulate(rotor(), 0.05, progress="short run"))
    out, err = capsys.readouterr()
    assert int(sol.num_segments) > 2 and int(sol.num_events) > 0  # several segments, one bar
    [line] = bars(err, "short run")
    assert "short run: 100%" in line and "0.0500 of 0.05 s" in line
    assert out == "" and err.count("\n") == 1 and "100.0 %" not in err
    assert reports[0] == 0.0 and reports[-1] == 1.0
    # a segment that ends at an event restarts just before the last step it reported (that
    # step ran past the event), so a 2 % cell may be reported twice; the bar never moves back
    assert all(b > a - 0.02 for a, b in zip(reports, reports[1:]))
    assert len(reports) <= 2 * 51  # at most twice per 2 % cell, however many segments
    assert not simulate_module._BARS  # closed at t1


def test_another_label_compiles_nothing(capsys, compiled_functions):
    """The label is a value of the compiled solve: the run of the test above under another label
    (the same module's worker, tests/conftest.py) shows that label's bar without compiling."""
    model = rotor()
    jax.block_until_ready(jb.simulate(model, 0.05, progress="short run"))  # compiled here
    capsys.readouterr()
    with compiled_functions() as compiles:
        jax.block_until_ready(jb.simulate(model, 0.05, progress="another label"))
    assert "jit(_simulate)" not in compiles
    _, err = capsys.readouterr()
    [line] = bars(err, "another label")
    assert "another label: 100%" in line and "0.0500 of 0.05 s" in line
    assert not bars(err, "short run") and not simulate_module._BARS


@pytest.mark.slow  # 7 s: a vmapped compile
def test_vmapped_runs_share_one_bar(capsys, reports):
    model = rotor()
    run = jax.vmap(
        lambda c: jb.simulate(
            eqx.tree_at(lambda m: m.bearing.clearance, model, c), 0.05, progress="batch"
        ).ball_loads
    )
    jax.block_until_ready(run(jnp.array([20e-6, 40e-6, 60e-6])))
    _, err = capsys.readouterr()
    [line] = bars(err, "batch")
    assert "batch: 100%" in line
    assert reports[0] == 0.0 and reports[-1] == 1.0 and len(reports) <= 2 * 51, len(reports)
