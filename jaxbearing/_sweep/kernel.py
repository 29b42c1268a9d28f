"""The sweep's kernel: one chunk of points as one jitted ``shard_map(map(point -> metrics))``
over a 1-D mesh of all JAX devices, and the point-by-point rerun of a chunk that raises.

On each device the members run one after another (`jax.lax.map`) on a CPU, and as one batch
(`jax.vmap`) on an accelerator. A CPU gains nothing from a batch: XLA:CPU compiles a single
member's loop into one function (`jaxbearing._process`), but not a vmapped one, whose step
combines the solver's stages in batched matrix products, which run kernel by kernel; and a
batch runs each iteration's step attempt and root-finder step for every member. Run one after
another, a member takes exactly the steps of its run alone; in a batch it agrees with that run
to the solver's tolerance (batched arithmetic rounds differently)."""

from __future__ import annotations

import re

import equinox as eqx
import jax
import jax.numpy as jnp
import numpy as np
from jax.sharding import NamedSharding, PartitionSpec as P

from .. import paths
from ..solution import RESULTS
from ..simulation import simulate, simulate_one_loop

AXIS = "d"  # name of the device axis of the mesh
SUCCESS = int(RESULTS.successful._value)
RAISED = -1  # status of a member whose solve raised an error (e.g. an equinox runtime check)
NOT_FINITE = -2  # status of a member whose solve succeeded but a metric is NaN or infinite
RUNTIME_ERRORS = (eqx.EquinoxRuntimeError, jax.errors.JaxRuntimeError)


class ChunkRunner:
    """Evaluates one chunk of points: pads it to ``padded`` rows (repeating the last point),
    runs the sharded kernel, gathers the results to the host and drops the padding."""

    def __init__(self, model, request, mesh, padded):
        self.names = request.names
        self.metric_items = request.metric_items
        self.t1 = request.t1
        self.sim_items = tuple(request.sim_kwargs.items())
        self.solve = request.solve
        self.mesh = mesh
        self.padded = padded
        replicated = NamedSharding(mesh, P())
        self.split = NamedSharding(mesh, P(AXIS))
        # host values in, so that the same code places them on a mesh spanning several hosts
        self.ts = jax.device_put(np.asarray(request.ts, np.float64), replicated)
        self.dynamic = jax.device_put(
            jax.tree_util.tree_map(np.asarray, eqx.filter(model, eqx.is_array)), replicated
        )
        self.static = eqx.filter(model, eqx.is_array, inverse=True)

    def __call__(self, chunk_points):
        """(values (n, n_metrics), status (n,) int32) of the chunk's n points."""
        n = chunk_points.shape[0]
        rows = np.concatenate([chunk_points, np.repeat(chunk_points[-1:], self.padded - n, axis=0)])
        rows = jax.device_put(rows, self.split)
        live = jax.device_put(np.arange(self.padded) < n, self.split)  # False: padding
        model = eqx.combine(self.dynamic, self.static)
        values, status = run_chunk(
            model, rows, live, self.ts, self.names, self.metric_items, self.t1, self.sim_items,
            self.solve, self.mesh,
        )
        values, status = _to_host((values, status))
        return values[:n], status[:n].astype(np.int32)

    def one_by_one(self, chunk_points):
        """Each point alone (its chunk filled with copies: no recompilation); a point whose
        solve raises gets status `RAISED`, NaN metrics and the error's first line."""
        n = chunk_points.shape[0]
        values = np.full((n, len(self.metric_items)), np.nan)
        status = np.full(n, RAISED, np.int32)
        errors = np.full(n, "", dtype=object)
        for i in range(n):
            try:
                v, c = self(chunk_points[i : i + 1])
            except RUNTIME_ERRORS as err:
                errors[i] = first_line(err)
                continue
            values[i], status[i] = v[0], c[0]
        return values, status, errors


def first_line(err, limit=300):
    """The message of a runtime error (equinox puts it after the stack inside JIT)."""
    lines = [line.strip() for line in str(err).splitlines() if line.strip()]
    for line in reversed(lines):
        found = re.match(r"^[\w.]*(?:Error|Exception): (.+)$", line)
        if found and not found.group(1).startswith("Above is the stack"):
            return found.group(1)[:limit]
    return (lines[0] if lines else repr(err))[:limit]


def _to_host(tree):
    if jax.process_count() > 1:
        from jax.experimental import multihost_utils

        return jax.tree_util.tree_map(np.asarray, multihost_utils.process_allgather(tree, tiled=True))
    return jax.tree_util.tree_map(np.asarray, tree)


def _member(model, row, ts, names, metric_items, t1, sim_kwargs, solve):
    """(metrics (n_metrics,), result code) of one point; NaN metrics where the solve failed."""
    m = paths.replace(model, dict(zip(names, row)))
    if solve == "one_loop":  # no output times
        sol = simulate_one_loop(m, t1, throw=False, **sim_kwargs)
    else:
        sol = simulate(m, t1, ts, throw=False, **sim_kwargs)
    code = jnp.asarray(sol.result._value, jnp.int32)
    ok = code == SUCCESS
    outs = []
    for name, metric in metric_items:
        value = jnp.asarray(metric.value(sol, m))
        if value.shape != ():
            raise ValueError(f"Metric {name!r} must return a scalar; it returned shape {value.shape}.")
        outs.append(jnp.where(ok, value.astype(jnp.float64), jnp.nan))
    return jnp.stack(outs), code


@eqx.filter_jit
def run_chunk(model, rows, live, ts, names, metric_items, t1, sim_items, solve, mesh):
    """The members of ``rows``, sharded over ``mesh``'s devices: one after another on each CPU
    device, where the padding (``live`` False) runs nothing, and vmapped on each accelerator
    (module docstring)."""
    dynamic, static = eqx.partition(model, eqx.is_array)
    sim_kwargs = dict(sim_items)
    on_cpu = mesh.devices.flat[0].platform == "cpu"

    def per_device(dynamic, rows, live, ts):
        def point(row):
            return _member(eqx.combine(dynamic, static), row, ts, names, metric_items, t1, sim_kwargs, solve)

        if not on_cpu:
            return jax.vmap(point)(rows)
        def skipped(row):  # a padding row: `_member`'s shapes, never read
            return jnp.zeros(len(metric_items)), jnp.zeros((), jnp.int32)

        return jax.lax.map(lambda a: jax.lax.cond(a[1], point, skipped, a[0]), (rows, live))

    sharded = jax.shard_map(
        per_device,
        mesh=mesh,
        in_specs=(P(), P(AXIS), P(AXIS), P()),
        out_specs=(P(AXIS), P(AXIS)),
        check_vma=False,
    )
    return sharded(dynamic, rows, live, ts)
