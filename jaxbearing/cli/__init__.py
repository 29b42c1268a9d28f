"""Command line: ``jaxbearing xu2014 [--out DIR] [--t1 0.2] [--samples N] [--config FILE]``.

Reproduces the paper's impact slider–crank (Xu 2014, Sect. 3): simulates 0–t1 with and without
the slider–target impact, prints a summary of each run and Table 5 side by side with the paper,
and writes into ``--out`` (default ``results/xu2014``):

- ``with_impact.csv``, ``without_impact.csv``: time series (columns in `jaxbearing.report`), every
  ``--csv-dt`` (default 10 µs) of simulated time;
- ``summary.json``: the run settings, the configuration file and its overrides, the package
  versions (`provenance.versions`), every parameter of both models by dotted path
  (`provenance.parameters`), each case's summary (`report.summarize` plus wall times) and the
  Table 5 comparison;
- ``fig12_slider_target.png`` ... ``fig15_ball_loads.png``: the paper's Figs. 12–15 over
  `cases.FIGURE_WINDOW` (one crank revolution), with and without impact overlaid. The summary
  says where each of its peaks (over the whole run) lies against them, and gives the figures'
  own peak where it lies outside (`report.figure_peaks`).

The memory the run needs (its output samples in up to `OUTPUT_COPIES` copies, the solve's
segment slots) is checked against the memory available before anything is solved: one line on
stderr naming both and the fix, exit status 2 (`_memory_problem`).

``--out`` is checked before anything is solved: a file, a folder that cannot be created or
written, or a folder that holds other files than a result of this command stops it with one
line on stderr (exit status 2). A run writes into a staging folder beside it,
``<out>.partial-<pid>-<random>``, marked by a file ``INCOMPLETE`` that says what it holds:
each case's CSV (and summary.json so far) as soon as that case is done, each file atomically,
the figures when both are. Only a complete run is moved into place (an earlier result in
``--out`` is renamed away, the new one renamed in, the old one deleted), so ``--out`` never
holds files of two runs. A run that stops early leaves ``--out`` as it was and says so in one
line on stderr; the staging folder keeps the cases it finished (it is deleted where there are
none):

- a failed solve: exit status 1, the figures of the cases finished drawn;
- any other error: the marker says so; an error of memory ends with exit status 1 and the fix,
  any other goes on with its traceback;
- Ctrl-C (SIGINT) or SIGTERM: exit status 130 or 143, at once, whatever is being computed, drawn
  or written (`_StopOnSignals`). Once the command has returned, SIGINT is ignored while the
  process ends.

The console shows what each case is doing and how long it took (stderr), the summaries and
Table 5; a warning says when --t1 stops before the slider first strikes the target (both cases
are then the same).

``--config FILE`` reads parameter overrides of the case from a TOML file, in SI units, e.g.

    [bearing]
    clearance = 60e-6     # [m]
    damping = 300.0       # [N s/m]
    [impact]
    restitution = 0.8

The tables and keys (bearing: clearance, damping, cage, ball_force; impact: restitution,
friction, contact_on; crank: speed) and the rules are in `jaxbearing.cli.config`. The file is checked
and both models are built before anything runs: an unknown key, a value of the wrong type (a
string such as "40 um", a boolean, an array) or one that breaks a rule of the model stops the
command with a message naming the file and the key or rule (exit status 2).
The physics and the numbers live in `jaxbearing.report`; this module only orchestrates.
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import shutil
import signal
import socket
import sys
import threading
import time
from pathlib import Path

DEFAULT_OUT = "results/xu2014"
DEFAULT_DT = 1e-6  # [s] output spacing: impacts last ~100 µs and their peaks need fine sampling
DEFAULT_CSV_DT = 1e-5  # [s] spacing of the CSV rows

OUTPUT_COPIES = 4  # copies of the output samples alive at once, at most (docs/xu2014.md, 'Memory')
SEGMENT_BYTES = 9  # [B] a segment slot of the solve's scan: its index (int64) and whether it ran
CASES = (("with_impact", "with impact", True), ("without_impact", "without impact", False))
FIRST_CONTACT = 0.091  # [s] first slider-target contact of the paper's case (docs/xu2014.md)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="jaxbearing", description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser(
        "xu2014",
        help="reproduce the paper's impact slider-crank (Figs. 12-15, Table 5)",
        description="Simulate Xu (2014)'s impact slider-crank with and without impact; print a "
        "summary and Table 5; write CSV, summary.json and Figs. 12-15 into --out.",
    )
    p.add_argument("--out", default=DEFAULT_OUT, help=f"output folder (default {DEFAULT_OUT})")
    p.add_argument("--t1", type=_number(0.0, False), default=0.2, help="final time [s] (default 0.2)")
    p.add_argument(
        "--samples",
        type=_count(2),
        default=None,
        help="number of output times over [0, t1] (default: one every 1 µs, 200001 for 0.2 s)",
    )
    p.add_argument(
        "--csv-dt", type=_number(0.0, False), default=DEFAULT_CSV_DT,
        help="CSV row spacing [s] (default 1e-5)",
    )
    p.add_argument("--rtol", type=_number(0.0, True), default=1e-8, help="relative tolerance (default 1e-8)")
    p.add_argument("--atol", type=_number(0.0, True), default=1e-10, help="absolute tolerance (default 1e-10)")
    p.add_argument(
        "--no-rerun",
        action="store_true",
        help="skip the second, compiled run that times the solve alone",
    )
    p.add_argument("--no-figures", action="store_true", help="do not draw the PNG figures")
    p.add_argument(
        "--config",
        default=None,
        metavar="FILE",
        help="TOML file of parameter overrides in SI units ([bearing] clearance, damping, cage, "
        "ball_force; [impact] restitution, friction, contact_on; [crank] speed; [metrics] "
        "window_start)",
    )
    p.set_defaults(func=run_xu2014)
    return parser


def _number(low: float, inclusive: bool):
    """An argparse type: a finite number above ``low`` (or equal to it, if ``inclusive``)."""
    bound = f">= {low:g}" if inclusive else f"> {low:g}"

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not (math.isfinite(value) and (value >= low if inclusive else value > low)):
            raise argparse.ArgumentTypeError(f"must be a finite number {bound}; got {text!r}")
        return value

    return parse


def _count(low: int):
    """An argparse type: an integer of at least ``low``."""

    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            value = low - 1
        if value < low:
            raise argparse.ArgumentTypeError(f"must be an integer of at least {low}; got {text!r}")
        return value

    return parse


def run_xu2014(args) -> int:
    """The ``xu2014`` command: check the settings, then run, report and write each case;
    SIGINT and SIGTERM stop it at once from the start (`_StopOnSignals`)."""
    with _StopOnSignals(getattr(args, "ends_process", False)) as stopper:
        return _xu2014(args, stopper)


def _xu2014(args, stopper) -> int:
    import jax

    jax.config.update("jax_enable_x64", True)
    from .. import cases
    from . import config

    try:
        overrides, source, models = _models(args, config)
    except config.ConfigError as err:
        print(f"jaxbearing xu2014: {err}", file=sys.stderr)
        return 2
    if args.rtol == 0.0 and args.atol == 0.0:
        print("jaxbearing xu2014: --rtol and --atol must not both be 0", file=sys.stderr)
        return 2
    problem = _memory_problem(args, models[True])
    if problem:
        print(f"jaxbearing xu2014: {problem}", file=sys.stderr)
        return 2
    ts, stride = _output_times(args)
    out = Path(args.out)
    problem = _out_problem(out)
    staging = None if problem else _Staging(out)
    problem = problem or staging.create()
    if problem:
        print(f"jaxbearing xu2014: --out {out}: {problem}", file=sys.stderr)
        return 2
    stopper.staging = staging
    contact_on = float(models[True].contacts[0].active_from)
    if args.t1 <= contact_on:
        _warn(f"--t1 {args.t1:g} s does not pass the time the slider-target contact switches on "
              f"(contact_on = {contact_on:g} s), so the cases with and without impact give the "
              f"same results; the first contact comes near t = {FIRST_CONTACT} s (paper's "
              "parameters): use --t1 0.1 or more.")  # fmt: skip
    summary = _summary(args, ts, stride, source, overrides, models)
    written: list[Path] = []
    done: dict = {}
    try:
        for key, label, impact in CASES:
            result = _run_case(args, models[impact], ts, label)
            if result is None:  # the solve failed (its message printed)
                if done and not args.no_figures:
                    _plot(staging.path, done)
                print(f"jaxbearing xu2014: {staging.stop(f'the solve of the case {label} failed')}",
                      file=sys.stderr)  # fmt: skip
                return 1
            sol, s = result
            if impact and args.t1 > contact_on and s["contact_count"] == 0:
                _warn(f"no slider-target contact in 0-{args.t1:g} s, so the cases with and "
                      "without impact give the same results; the first contact comes near "
                      f"t = {FIRST_CONTACT} s (paper's parameters).")  # fmt: skip
            window = None if args.no_figures else cases.FIGURE_WINDOW
            written += _write_case(staging.path, key, label, impact, sol, s, summary, stride, done, window)
            staging.finished(label)
        if not args.no_figures:
            written += _plot(staging.path, done)
        staging.commit()
    except KeyboardInterrupt:  # raised, not signalled: `_StopOnSignals` handles SIGINT
        print(f"jaxbearing xu2014: {staging.stop('stopped (KeyboardInterrupt)')}", file=sys.stderr)
        return 130
    except Exception as err:  # the staging folder says so; an error of memory ends here
        memory = _out_of_memory(err)
        why = f"failed: {'out of memory' if memory else type(err).__name__} ({_first_line(err)})"
        print(f"jaxbearing xu2014: {staging.stop(why)}", file=sys.stderr)
        if memory:
            print("jaxbearing xu2014: pass fewer --samples or a shorter --t1", file=sys.stderr)
            return 1
        raise
    _print_end(summary, out, [out / path.name for path in written])
    return 0


INCOMPLETE = "INCOMPLETE"  # the marker file of a staging folder


def _result_files() -> set[str]:
    """What a complete run writes into --out."""
    from ..report._figures import FIGURE_FILES

    return {*(f"{key}.csv" for key, _, _ in CASES), "summary.json", *FIGURE_FILES}


def _out_problem(out: Path) -> str | None:
    """Why ``--out`` cannot take the run's result, or None: a file; a folder that is read-only
    or holds other files than a result of this command (`_result_files`; replacing it would
    delete them)."""
    if out.exists() and not out.is_dir():
        return "is a file, not a folder: name a folder (it is created if missing)"
    if not out.exists():
        return None
    if not os.access(out, os.W_OK | os.X_OK):
        return "is a read-only folder: name a folder this process may write"
    ours = _result_files()
    foreign = sorted(p.name for p in out.iterdir() if p.name not in ours and not _is_temporary(p.name))
    if foreign:
        shown = ", ".join(foreign[:3]) + (", ..." if len(foreign) > 3 else "")
        return (f"holds files that are not a result of this command ({shown}), which replacing "
                "it by the new result would delete: name another folder, or empty it")  # fmt: skip
    return None


def _is_temporary(name: str) -> bool:
    """A file being written, or left by a writer that was killed (`_files.atomic_path`)."""
    return name.startswith(".") and name.endswith(".tmp")


class _Staging:
    """The folder a run writes into, ``<out>.partial-<pid>-<random>`` beside ``--out``, and its
    marker file (`INCOMPLETE`), which says what it holds while the run is not complete. ``commit``
    moves a complete run into place; ``stop`` says where an incomplete one is."""

    def __init__(self, out: Path):
        self.out = out
        self.path: Path | None = None  # made by `create`
        self.cases: list[str] = []  # the labels of the cases finished
        self.lock = threading.Lock()  # held while the folder is moved or its marker rewritten
        self.committed = False
        self.started = time.strftime("%Y-%m-%d %H:%M:%S")

    def create(self) -> str | None:
        """Create the folder (and --out's parents) with its marker; why not, or None."""
        try:
            self.out.parent.mkdir(parents=True, exist_ok=True)
            self.path = self._new_folder("partial")
            self._mark("The run is going on (or was killed).")
        except OSError as err:
            return f"cannot write beside it, in {self.out.parent.resolve()} ({err.strerror})"
        return None

    def _new_folder(self, kind: str) -> Path:
        """A new folder ``<out>.<kind>-<pid>-<random>`` beside --out (`_files.new_folder`)."""
        from .. import _files

        return _files.new_folder(self.out.parent, f"{self.out.name}.{kind}-{os.getpid()}-")

    def finished(self, label: str) -> None:
        with self.lock:
            self.cases.append(label)
            self._mark("The run is going on (or was killed).")

    def _mark(self, status: str) -> None:
        from .. import _files

        done = ", ".join(self.cases) or "no case"
        _files.write_text(self.path / INCOMPLETE, (
            f"This folder holds an incomplete run of `jaxbearing xu2014` (process {os.getpid()}, "
            f"started {self.started}), meant for {self.out}.\n"
            f"{status}\nFinished: {done} (their CSV and summary.json); a run moves its folder to "
            f"{self.out} only when it is complete, and removes this file then.\n"
        ))  # fmt: skip

    def commit(self) -> None:
        """Move the complete run into place: an earlier --out renamed away, this one renamed
        in, the earlier one deleted."""
        with self.lock:
            (self.path / INCOMPLETE).unlink()
            replaced = self.out.exists()
            if replaced:
                old = self._new_folder("old")
                os.rename(self.out, old)  # onto the empty folder
            os.rename(self.path, self.out)
            self.committed = True
        if replaced:
            shutil.rmtree(old)

    def stop(self, why: str) -> str:
        """Leave the incomplete run where it is, its marker saying ``why`` it stopped (the
        folder deleted where it holds no case); the one line that says so."""
        with self.lock:
            if self.committed:
                return f"{why}, after the run was complete: the files are in {self.out}"
            for tmp in self.path.iterdir():
                if _is_temporary(tmp.name):
                    tmp.unlink(missing_ok=True)
            kept = "is as it was" if self.out.exists() else "was not created"
            if not self.cases:
                shutil.rmtree(self.path, ignore_errors=True)
                return f"{why} before any case was finished; nothing was written ({self.out} {kept})"
            self._mark(f"Stopped: {why}.")
            return (f"{why}; the cases finished ({', '.join(self.cases)}) are in {self.path}, marked "
                    f"{INCOMPLETE}; {self.out} {kept}")  # fmt: skip


class _StopOnSignals:
    """In its block, SIGINT (Ctrl-C) and SIGTERM stop the process at once with the staging
    folder's line (`_Staging.stop`) and the exit status 128 + the signal's number (130, 143),
    whatever the main thread is doing. Python runs signal handlers in the main thread between
    bytecodes, so an exception raised there waits for a compile of tens of seconds in XLA and
    can be swallowed where it lands (a garbage-collection callback); here the handlers do
    nothing and the signal's number, which CPython writes to its wakeup descriptor as the
    signal arrives (`signal.set_wakeup_fd`), wakes a thread that stops the process
    (`os._exit`). Nothing is installed outside the main thread, where Python takes no
    signals.

    Where the command ends the process (``ends_process``), SIGINT is ignored once the block is
    left: the exit status is decided, and a Ctrl-C while the interpreter shuts down would be
    raised inside JAX's exit handlers (which free the backends and compiled programs) as a
    KeyboardInterrupt traceback, or end the process with -2 after them. SIGTERM keeps its
    default (the process ends, without a traceback)."""

    SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self, ends_process: bool = False):
        self.staging: _Staging | None = None  # set once the run has one
        self.installed = threading.current_thread() is threading.main_thread()
        self.ends_process = ends_process

    def __enter__(self):
        if not self.installed:
            return self
        self.reader, self.writer = socket.socketpair()
        self.writer.setblocking(False)
        self.previous = [signal.signal(n, lambda *_: None) for n in self.SIGNALS]
        self.previous_fd = signal.set_wakeup_fd(self.writer.fileno(), warn_on_full_buffer=False)
        threading.Thread(target=self._watch, name="jaxbearing-stop", daemon=True).start()
        return self

    def __exit__(self, *exc):
        if not self.installed:
            return
        for number, handler in zip(self.SIGNALS, self.previous):  # first: no signal is lost
            ending = self.ends_process and number == signal.SIGINT
            signal.signal(number, signal.SIG_IGN if ending else handler)
        signal.set_wakeup_fd(self.previous_fd)
        self.writer.close()  # ends the thread's wait

    def _watch(self):
        with self.reader:
            while data := self.reader.recv(1):
                if data[0] in self.SIGNALS:
                    self._stop(data[0])

    def _stop(self, number: int):
        why = f"stopped by {signal.Signals(number).name}"
        line = f"{why}; nothing was written"
        try:
            if self.staging is not None:
                line = self.staging.stop(why)
        except Exception as err:  # the process stops all the same
            line = f"{why} ({type(err).__name__}: {err}); the run's files are in {self.staging.path}"
        finally:
            with contextlib.suppress(OSError):
                os.write(2, f"jaxbearing xu2014: {line}\n".encode())
            os._exit(128 + number)


def _plot(out, done) -> list[Path]:
    from .. import cases, report

    return report.plot_figures(out, done, cases.FIGURE_WINDOW)


def _models(args, config):
    """(overrides, their file or None, {impact: model}); `config.ConfigError` when invalid."""
    overrides, source = {}, None
    if args.config is not None:
        source = str(Path(args.config).resolve())
        overrides = config.read_overrides(source)
    return overrides, source, config.xu2014_models(overrides, source or "the default parameters")


def _output_times(args):
    """(output times [s], CSV stride in samples) of the command's options."""
    import numpy as np

    samples = _sample_count(args)
    dt = args.t1 / (samples - 1)
    return np.linspace(0.0, args.t1, samples), max(1, round(args.csv_dt / dt))


def _sample_count(args) -> int:
    """Output times of the command's options (`_output_times`), without making them."""
    return args.samples if args.samples is not None else max(2, round(args.t1 / DEFAULT_DT) + 1)


def _floats_per_output(model) -> int:
    """Floats a solution of ``model`` holds per output time: t, q, qd, qdd, each bearing's ball
    loads, force (2) and cage angle, each contact's force, penetration and approach speed, and
    the drift (`solution.Samples`); its series (`report.series`) copy them."""
    bearings = sum(joint.bearing.n_balls + 3 for joint in model.bearings)
    return 2 + 3 * model.n_coordinates + bearings + 3 * len(model.contacts)


def _memory_problem(args, model) -> str | None:
    """Why the run does not fit in the memory available, or None: the output samples, in up to
    `OUTPUT_COPIES` copies (the solve's, its NumPy series and the first case's kept for the
    figures), and the solve's scan of ``default_max_segments`` slots. Checked before anything
    is solved, where the sizes are known (docs/xu2014.md, 'Memory')."""
    from .. import default_max_segments

    available = _available_memory()
    if available is None:
        return None
    samples = _sample_count(args)
    per_output = 8 * OUTPUT_COPIES * _floats_per_output(model)
    segments = SEGMENT_BYTES * default_max_segments(model, 0.0, args.t1)
    need = samples * per_output + segments
    if need <= available:
        return None
    fitting = (available - segments) // per_output
    fix = (f"pass --samples {fitting} or fewer, or a shorter --t1" if fitting >= 2
           else "use a shorter --t1")  # fmt: skip
    return (f"--t1 {args.t1:g} s with {samples} output times needs about {_size(need)} of memory "
            f"({per_output} B an output time, {_size(segments)} for the solve's segments), more "
            f"than the {_size(available)} available: {fix}")  # fmt: skip


def _available_memory() -> int | None:
    """Bytes of memory this process may still take [B]: the host's (Linux: MemAvailable), and
    the accelerator's free memory where JAX reports a limit, whichever is less; None where
    neither is known."""
    import jax

    known = []
    try:
        with open("/proc/meminfo") as f:
            known += [int(line.split()[1]) * 1024 for line in f if line.startswith("MemAvailable:")]
    except OSError:
        with contextlib.suppress(ValueError, OSError, AttributeError):
            known.append(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    device = jax.devices()[0]
    stats = device.memory_stats() if device.platform != "cpu" else None
    if stats and "bytes_limit" in stats:
        known.append(stats["bytes_limit"] - stats.get("bytes_in_use", 0))
    return min(known) if known else None


def _size(n: int) -> str:
    """A byte count in words (decimal units)."""
    for unit, scale in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6)):
        if n >= scale:
            return f"{n / scale:.3g} {unit}"
    return f"{n / 1e3:.3g} kB"


def _out_of_memory(err: BaseException) -> bool:
    """Whether ``err`` says that memory ran out (Python's, or XLA's RESOURCE_EXHAUSTED)."""
    import jax

    return isinstance(err, MemoryError) or (
        isinstance(err, jax.errors.JaxRuntimeError) and "RESOURCE_EXHAUSTED" in str(err)
    )


def _first_line(err: BaseException) -> str:
    return (str(err).strip().splitlines() or [""])[0][:300]


def _window_start(model) -> float:
    """Where the model's metrics window starts [s] (0 for a model without one)."""
    return 0.0 if model.window_start is None else float(model.window_start)


def _warn(message):
    print(f"jaxbearing xu2014: warning: {message}", file=sys.stderr, flush=True)


def _summary(args, ts, stride, source, overrides, models) -> dict:
    """summary.json before any case has run: the settings and every parameter."""
    from .. import cases, provenance

    dt = args.t1 / (ts.size - 1)
    return {
        "case": "xu2014 impact slider-crank (Xu 2014, Sect. 3; docs/model.md, 'The paper's case')",
        "t1_s": args.t1,
        "samples": int(ts.size),
        "output_dt_s": dt,
        "csv_dt_s": stride * dt,
        "csv_columns": None,
        "rtol": args.rtol,
        "atol": args.atol,
        "peak_window_from_s": _window_start(models[True]),
        "figure_window_s": list(cases.FIGURE_WINDOW),
        "config_file": source,
        "overrides": overrides,
        "versions": provenance.versions(),
        "parameters": {key: provenance.parameters(models[impact]) for key, _, impact in CASES},
        "cases": {},
        "table5": None,
    }


class _CacheEvents:
    """Counts JAX's persistent-cache hits and writes (`jax.monitoring` events) in its block."""

    EVENTS = {"/jax/compilation_cache/cache_hits": "hits", "/jax/compilation_cache/cache_misses": "writes"}

    def __enter__(self):
        import jax.monitoring

        self.counts = {"hits": 0, "writes": 0}
        jax.monitoring.register_event_listener(self._event)
        return self

    def __exit__(self, *exc):
        import jax.monitoring

        jax.monitoring.unregister_event_listener(self._event)

    def _event(self, event, **kwargs):
        if event in self.EVENTS:
            self.counts[self.EVENTS[event]] += 1

    def said(self) -> str:
        """What the cache did, in words."""
        hits, writes = self.counts["hits"], self.counts["writes"]
        if hits and writes:
            return "compiled in part, the rest from this machine's compilation cache"
        if hits:
            return "the compiled model came from this machine's compilation cache"
        if writes:
            return "compiled: first run of this model on this machine; stored in the compilation cache"
        return "compiled; the compilation cache is off"


def _run_case(args, model, ts, label):
    """(solution, summary with life and wall times) of one case; None (message printed) when
    the solve fails."""
    import jax

    from .. import SimulationError, default_controller, report, simulate

    def solve():
        controller = default_controller(args.rtol, args.atol)
        return jax.block_until_ready(simulate(model, args.t1, ts, stepsize_controller=controller))

    # no progress bar inside the solve: its host callbacks would keep the compiled solve out of
    # JAX's persistent compilation cache, and the run itself takes a fraction of a second
    print(f"{label}: compiling the model (or loading it from this machine's compilation cache) "
          f"and solving 0-{args.t1:g} s ...", file=sys.stderr, flush=True)
    start = time.perf_counter()
    try:
        with _CacheEvents() as cache:
            sol = solve()
    except SimulationError as err:
        print(f"{label}: {err}", file=sys.stderr)
        return None
    wall_first = time.perf_counter() - start
    print(f"{label}: done in {wall_first:.1f} s ({cache.said()})", file=sys.stderr, flush=True)
    wall_second = None
    if not args.no_rerun:
        start = time.perf_counter()
        solve()
        wall_second = time.perf_counter() - start
    s = report.summarize(sol, _window_start(model), model)
    s["wall_first_s"] = wall_first
    s["wall_second_s"] = wall_second
    return sol, s


def _write_case(out, key, label, impact, sol, s, summary, stride, done, window) -> list[Path]:
    """Write one case's CSV and the summary so far; print it; add its series to ``done``. With
    the figures' ``window`` [s] (None: no figures), the summary holds the peaks they show
    (`report.figure_peaks`) and says where the run's lie against them."""
    from .. import cases, report

    data = report.series(sol)
    if window is not None:
        s.update(report.figure_peaks(data, window))
    summary["cases"][key] = s
    summary["csv_columns"] = report.csv_columns(data)
    written = [report.write_csv(out / f"{key}.csv", data, stride)]
    if not impact and len(report.ball_keys(data)) == len(cases.TABLE5):
        # Table 5 holds the paper's 8 balls: a bearing of another designation has no table
        summary["table5"] = report.table5_summary(data)
    written.append(report.write_json(out / "summary.json", summary))
    print(report.format_summary(label, s), flush=True)
    done[label] = data
    return written


def _print_end(summary, out, written):
    from .. import report

    if summary["table5"] is not None:
        print(report.format_table5(summary["table5"]))
    print(f"files in {out}:")
    for path in sorted(set(written)):
        print(f"  {path.name:<26} {path.stat().st_size / 1024:10.1f} KiB")


def main(argv=None) -> int:
    """Entry point of the ``jaxbearing`` command; returns the exit status. ``argv`` None: the
    process's own command line, which the command ends, so that SIGINT is ignored from its end
    on (`_StopOnSignals`)."""
    args = build_parser().parse_args(argv)
    args.ends_process = argv is None
    return args.func(args)
