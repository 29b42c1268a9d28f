import contextlib
import os
import time

import jax
import pytest

jax.config.update("jax_enable_x64", True)

# The suite's time is mostly compilation: each distinct static configuration of `simulate` (the
# model's structure, the number of output times above 2 048, the segment slots that the span sets, the
# options; not rtol, atol, max_steps or parameter values) compiles the solve anew, in each
# pytest-xdist worker that meets it before another worker has put it into JAX's persistent cache
# (which jaxbearing turns on; workers compiling the same solve at once both compile it). So tests
# that share a compiled solve or a module-scoped fixture (a simulation, a command-line run, the
# sweep's subprocesses) run on one worker (`--dist loadgroup` in pyproject.toml), and these
# groups are handed out first, so that neither worker ends alone on a whole group; the other
# tests follow one by one.
SHARED = {  # modules, each a group
    "test_clearance_joint", "test_compile", "test_hertz", "test_impact",
    "test_multibody", "test_progress", "test_rotor_metrics", "test_sweep",
    "test_records", "test_two_bearings", "test_report_draw", "test_elements", "test_step_size",
}
MODULE_GROUPS = {  # modules that share compiled solves: one group
    # the paper's case over 0-0.2 s, up to 2048 output times, with impact and without
    "paper_0.2s": ("test_xu2014", "test_cli", "test_life", "test_one_loop", "test_converged"),
    # the paper's case without impact over 0-0.02 s at 201 output times (below), pauses and
    # the metrics against dense samples
    "free_0.02s": ("test_pauses", "test_metrics_exact"),
    # the paper's case over 0-0.005 s (up to 2048 output times; its contact, switched on at
    # 0.05 s, does not act yet)
    "paper_0.005s": ("test_transforms", "test_validation", "test_windows", "test_fail_safe"),
    # a rotor in the SKF 98205 under a steady load, 256 segment slots (a span up to 0.06 s)
    "rotor_98205": ("test_rollers", "test_reference_life"),
}
COMPILE_GROUPS = {  # tests of several modules that share one compiled solve
    # the paper's case without impact, 0-0.02 s, 201 output times, default options
    "free_0.02s": (
        "test_derivatives.py::test_sensitivities_without_impact[paper]",
        "test_scipy_baseline.py::test_no_impact_start_agrees",
    ),
    # the four-bar over two crank turns, up to 2048 output times: the page's example, then the test
    "four_bar": (
        "test_docs.py::test_the_page_s_code_runs[docs/mechanisms.md]",
        "test_four_bar.py::test_bearing_force_converges_to_the_rigid_pin_reaction",
    ),
    # the paper's case, a 2 x 2 sweep of clearance and restitution over 0.2 s, default metrics
    "paper_sweep": (
        "test_notebooks.py::test_notebook_runs[sweeps.ipynb]",
        "test_studies.py::test_study_runs_quick[clearance_sweep.py]",
    ),
    "paper_0.005s": (
        "test_compile.py::test_tolerances_and_step_limit_compile_nothing_new",
        "test_compile.py::test_fewer_output_times_compile_nothing_new",
        "test_compile.py::test_a_python_float_put_into_the_model_compiles_nothing_new",
    ),
}
_GROUP_OF = {test: group for group, tests in COMPILE_GROUPS.items() for test in tests}
_GROUP_OF_MODULE = {module: group for group, modules in MODULE_GROUPS.items() for module in modules}
# the longest tests (docs/testing.md), handed out before all others: a worker that starts one
# last would run on alone, and under .ci/run's --start-before it would not start at all
LONGEST = (
    "test_derivatives.py::test_derivatives_with_impact",  # the slow set's
    # the default set's longest that share no compiled solve with other tests (about 10-17 s)
    "test_tune.py::test_tune_returns_the_best_valid_iterate_past_an_invalid_clearance",
    "test_tune.py::test_a_batch_of_tangents_matches_central_differences",
)


def _test(item) -> str:
    """``module.py::test[param]``, the form of COMPILE_GROUPS and LONGEST."""
    path, _, test = item.nodeid.partition("::")
    return f"{path.rsplit('/', 1)[-1]}::{test}"


def _group(item):
    module = item.module.__name__
    return _GROUP_OF.get(_test(item)) or _GROUP_OF_MODULE.get(module) or (module if module in SHARED else None)


@pytest.hookimpl(tryfirst=True)  # before pytest-xdist reads the marks
def pytest_collection_modifyitems(items):
    grouped = set()
    for item in items:
        group = _group(item)
        if group:
            item.add_marker(pytest.mark.xdist_group(group))
            grouped.add(item.nodeid)
    # stable sort: the longest tests, then the groups, then the others, each in file order
    items.sort(key=lambda item: (not _test(item).startswith(LONGEST), item.nodeid not in grouped))


@pytest.hookimpl(trylast=True)  # after pytest-xdist's worker has named the groups
def pytest_collection_finish(session):
    """pytest-xdist's worker sends a test's group to the scheduler as a suffix of its node id;
    pytest 9.2 keeps node ids apart from the field it writes (pytest-xdist#1386), and the groups
    are then dropped without a word: every group's compiles happen on both workers, a third
    more time (pyproject.toml keeps pytest below 9.2)."""
    if not getattr(session.config.option, "loadgroup", False):
        return  # not an xdist worker under --dist loadgroup
    lost = [item for item in session.items if _group(item) and "@" not in item.nodeid]
    if lost:
        session.config.issue_config_time_warning(pytest.PytestWarning(
            f"pytest-xdist's groups have no effect with pytest {pytest.__version__} "
            f"({len(lost)} tests, e.g. {lost[0].nodeid}; pytest-xdist#1386): the tests pass, more "
            "slowly; use pytest below 9.2 (pyproject.toml)"), stacklevel=2)


def pytest_addoption(parser):
    parser.addoption(
        "--start-before", type=float, default=None, metavar="UNIX_TIME",
        help="start no test after this time (seconds since the epoch): later ones are skipped, "
        "each named in the summary. .ci/run's time budget for the slow tests.",
    )


@pytest.hookimpl(tryfirst=True)  # before the test's fixtures are set up
def pytest_runtest_setup(item):
    deadline = item.config.getoption("--start-before")
    if deadline is not None and time.time() > deadline:
        pytest.skip(f"{item.nodeid} not started: the time budget of --start-before was spent")


@pytest.fixture
def compiled_functions():
    """A context manager that gives the list of the functions JAX traces or compiles while it is
    open (their ``fun_name`` in JAX's monitoring events, e.g. ``"jit(_simulate)"``)."""

    @contextlib.contextmanager
    def collect():
        names = []
        listener = lambda event, duration, **kw: names.append(kw.get("fun_name"))  # noqa: E731
        jax.monitoring.register_event_duration_secs_listener(listener)
        try:
            yield names
        finally:
            jax.monitoring.unregister_event_duration_listener(listener)

    return collect


@pytest.fixture
def own_cache_env():
    """A function of ``**env``: this process's environment without any setting of jaxbearing's
    or of JAX's cache, plus ``env``; a child process then gets the cache that importing
    jaxbearing turns on."""

    def environment(**env):
        drop = ("JAXBEARING_", "JAX_COMPILATION", "JAX_PERSISTENT")
        return {**{k: v for k, v in os.environ.items() if not k.startswith(drop)}, **env}

    return environment
