"""Which tests compile which solve (issue 75, item 4): a pytest plugin that logs every call of
`simulate`'s compiled solve with the test that made it, the digest of its static configuration
and its wall (a first call includes the trace and the compile), and a report of that log.

    XDG_CACHE_HOME=$(mktemp -d) PYTHONPATH=benchmarks python -m pytest -p suite_compiles
    python benchmarks/suite_compiles.py [FOLDER]

The configuration is what `eqx.filter_jit` keys the compiled solve on: the tree structure and
the static leaves of its arguments (the model's structure and names, the solver and controller,
the options with the segment counts resolved) and the shapes of its arrays. Two tests that
differ in it compile two solves; those that agree share one on a worker, and across workers
through JAX's persistent cache. The log goes to FOLDER (``$JAXBEARING_COMPILE_LOG``, by default
``jaxbearing-suite-compiles`` in the temporary folder): one JSON line per call in
``<pid>.jsonl``, each configuration written out in ``<digest>.txt`` to compare two of them.
The report lists the configurations by their longest call, with their tests.
"""

from __future__ import annotations

import collections
import hashlib
import json
import os
import re
import sys
import tempfile
import time
from pathlib import Path

FOLDER = Path(
    os.environ.get("JAXBEARING_COMPILE_LOG")
    or Path(tempfile.gettempdir()) / "jaxbearing-suite-compiles"
)


def configuration(args) -> str:
    """The static configuration of the compiled solve's arguments, as text (the same in every
    process)."""
    import equinox as eqx
    import jax

    dynamic, static = eqx.partition(args, eqx.is_array)
    leaves, structure = jax.tree_util.tree_flatten(static)
    shapes = [(tuple(x.shape), str(x.dtype)) for x in jax.tree_util.tree_leaves(dynamic)]
    # a function's address differs from process to process, its name does not
    return re.sub(r" at 0x[0-9a-f]+", "", f"{structure}\n{leaves!r}\n{shapes!r}")


def pytest_configure(config):
    """Wrap `jaxbearing.simulation._simulate` in this process (each pytest-xdist worker)."""
    from jaxbearing import simulation

    FOLDER.mkdir(parents=True, exist_ok=True)
    solve = simulation._simulate
    log = FOLDER / f"{os.getpid()}.jsonl"

    def logged(*args):
        text = configuration(args)
        digest = hashlib.sha1(text.encode()).hexdigest()[:12]
        start = time.perf_counter()
        out = solve(*args)
        wall = time.perf_counter() - start
        test = os.environ.get("PYTEST_CURRENT_TEST", "?").rsplit(" (", 1)[0]
        with log.open("a") as f:
            f.write(json.dumps({"digest": digest, "test": test, "wall_s": wall}) + "\n")
        written = FOLDER / f"{digest}.txt"
        if not written.exists():
            written.write_text(text)
        return out

    simulation._simulate = logged


def report(folder: Path) -> None:
    """Print each configuration's longest call, its calls and its tests, longest first."""
    calls = collections.defaultdict(list)
    for path in folder.glob("*.jsonl"):
        for line in path.read_text().splitlines():
            row = json.loads(line)
            calls[row["digest"]].append((row["wall_s"], row["test"], path.stem))
    rows = sorted(((max(c)[0], d, c) for d, c in calls.items()), reverse=True)
    for wall, digest, c in rows:
        tests = sorted({t for _, t, _ in c})
        workers = len({w for _, _, w in c})
        print(f"{wall:7.2f} s  {digest}  {len(c)} calls, {workers} process(es): {tests[0]}")
        for test in tests[1:]:
            print(f"{'':23}{test}")
    print(f"{len(rows)} configurations; their longest calls {sum(r[0] for r in rows):.1f} s in all")


if __name__ == "__main__":
    report(Path(sys.argv[1]) if len(sys.argv) > 1 else FOLDER)
