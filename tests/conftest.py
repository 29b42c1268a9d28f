import jax
import pytest

jax.config.update("jax_enable_x64", True)

# Modules whose tests share module-scoped fixtures (a simulation, a command-line run, the sweep
# subprocesses) or compiled solves: each runs on one pytest-xdist worker (`--dist loadgroup` in
# pyproject.toml), so that the other worker does not compute them again. They are handed out
# first, so that neither worker ends alone on a whole module; the other tests follow one by one.
SHARED = {
    "test_cli", "test_hertz", "test_impact", "test_life", "test_metrics_exact", "test_multibody",
    "test_rotor_metrics", "test_sweep", "test_transforms", "test_windows", "test_xu2014",
}


@pytest.hookimpl(tryfirst=True)  # before pytest-xdist reads the marks
def pytest_collection_modifyitems(items):
    for item in items:
        if item.module.__name__ in SHARED:
            item.add_marker(pytest.mark.xdist_group(item.module.__name__))
    items.sort(key=lambda item: item.module.__name__ not in SHARED)  # stable: file order kept
