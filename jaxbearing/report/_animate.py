"""The motion of a simulated machine as a matplotlib animation (`animate`): the picture of
`draw` moved through a `Solution`'s samples, with its bearings' rolling-element loads as bars
and an optional panel of any sampled quantity against time under a moving time marker."""

from __future__ import annotations

import tempfile
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from .. import _checks, _files
from ._draw import Frame, Scene, checked_scale, finish, has_play

LOAD_BAR = 0.6  # the largest load's bar is this fraction of the largest outer raceway's radius
MIN_ASPECT = 0.4  # the machine's Axes are at least this high over wide
WIDTH = 6.4  # [in] of the figure when not given
PANEL_HEIGHT = 1.5  # [in] of the panel


def frame_indices(ts, q, window, frames: int) -> np.ndarray:
    """Indices of at most ``frames`` samples evenly spread over the finite samples inside
    ``window`` (t_start, t_end) [s] (None: all)."""
    if isinstance(frames, bool) or not isinstance(frames, (int, np.integer)) or frames < 1:
        raise ValueError(f"frames must be a positive integer; got {frames!r}.")
    ts = np.asarray(ts, dtype=float)
    inside = np.isfinite(ts) & np.all(np.isfinite(np.asarray(q, dtype=float)), axis=-1)
    if window is not None:
        start, end = (float(x) for x in window)
        inside &= (ts >= start) & (ts <= end)
    candidates = np.flatnonzero(inside)
    if candidates.size == 0:
        raise ValueError(f"No finite sample of the solution lies in the window {window} [s].")
    if candidates.size <= frames:
        return candidates
    return candidates[np.round(np.linspace(0, candidates.size - 1, frames)).astype(int)]


def _panel_series(panel, n_samples: int) -> dict[str, np.ndarray]:
    """``panel`` (a (T,) array, or a mapping label -> (T,) array) as a dict of float arrays."""
    series = dict(panel) if isinstance(panel, Mapping) else {"": panel}
    out = {}
    for label, values in series.items():
        values = np.asarray(values, dtype=float)
        if values.shape != (n_samples,):
            raise ValueError(
                f"panel series {label!r} must have one value per output time, shape "
                f"({n_samples},); got {values.shape}."
            )
        out[str(label)] = values
    return out


def _load_scale(model, sol, indices) -> tuple[float | None, float]:
    """[m/N] of the load bars (None without bearings or loads) and the largest load [N]."""
    if not model.bearings:
        return None, 0.0
    loads = [np.asarray(b.ball_loads, dtype=float)[indices] for b in sol.bearings]
    largest = max((float(np.nanmax(x)) for x in loads if np.isfinite(x).any()), default=0.0)
    if not largest > 0.0:
        return None, 0.0
    radius = max(float(b.bearing.outer_race_diameter) / 2 for b in model.bearings)
    return LOAD_BAR * radius / largest, largest


def animate(
    sol,
    model,
    *,
    frames: int = 60,
    window=None,
    panel=None,
    ylabel: str = "",
    path=None,
    fps: float = 15.0,
    clearance_scale=None,
    labels: bool = True,
    figsize=None,
    dpi: float = 100.0,
):
    """The motion of ``model`` in ``sol`` as a matplotlib animation, one frame per chosen sample.

    Each frame is `draw`'s picture at a sample's coordinates, its bearings' cages at their
    recorded angles and each rolling element's load as a bar outside the outer raceway (one
    scale for all, stated in the Axes). The frames are the samples (the output times of the
    solve, not interpolated) evenly spread over ``window``.

    Args:
        sol: the `Solution` of a `simulate` of ``model`` (one, not a batch).
        model: the `Mechanism` simulated.
        frames: the most frames; the window's samples if fewer.
        window: (t_start, t_end) [s]; None: the whole solution (samples a failed solve did not
            reach are left out).
        panel: a quantity to plot against time under the machine, with a marker at each
            frame's time: a (T,) array at the output times, or a mapping label -> (T,) array
            (e.g. ``{"contact 0 [N]": sol.contact_forces[:, 0]}``); None: no panel.
        ylabel: the panel's axis label (with the unit).
        path: a file to write the animation to, atomically: ``.gif`` (Pillow, which comes
            with matplotlib) or a video format ffmpeg writes (``.mp4``; ffmpeg on the PATH).
        fps: frames per second of the written file and of the notebook player.
        clearance_scale: the factor the bearings' clearances and eccentricities are drawn by
            (None: `draw`'s default for the model).
        labels: write the bodies' names and the elements' labels.
        figsize, dpi: of the figure [in], [dots per inch].

    Returns:
        The `matplotlib.animation.FuncAnimation`; in a notebook,
        ``IPython.display.HTML(anim.to_jshtml())`` shows it inline (no ffmpeg needed), and
        ``anim.to_html5_video()`` does with ffmpeg.
    """
    from matplotlib.animation import FuncAnimation
    from matplotlib.figure import Figure

    if np.ndim(sol.ts) != 1:
        raise ValueError(
            f"animate takes one solution; this one has output times of shape {np.shape(sol.ts)} "
            "(a batch: pick one member first, e.g. with jax.tree_util.tree_map)."
        )
    model = _checks.on_host(model)
    scale = checked_scale(model, clearance_scale)
    writer = None if path is None else writer_for(path, fps)
    ts, q = np.asarray(sol.ts, dtype=float), np.asarray(sol.q, dtype=float)
    indices = frame_indices(ts, q, window, frames)
    series = None if panel is None else _panel_series(panel, ts.size)
    cages = [np.asarray(b.cage_angle, dtype=float) for b in sol.bearings]
    loads = [np.asarray(b.ball_loads, dtype=float) for b in sol.bearings]
    load_scale, largest = _load_scale(model, sol, indices)

    def frame_at(i: int) -> Frame:
        return Frame(q[i], tuple(c[i] for c in cages), tuple(x[i] for x in loads))

    fig = Figure(figsize=figsize or (WIDTH, WIDTH), dpi=dpi, layout="constrained")
    if series:
        ax, panel_ax = fig.subplots(2, 1, height_ratios=(3, 1))
    else:
        ax, panel_ax = fig.add_subplot(), None
    scene = Scene(ax, model, frame_at(indices[0]), scale, load_scale, labels)
    aspect = _fix_limits(ax, scene, [frame_at(i) for i in indices])
    if figsize is None:  # the machine's Axes as wide as the figure, its labels and the panel below
        machine = min(0.8 * WIDTH * aspect, 1.2 * WIDTH)
        panel_height = PANEL_HEIGHT if series else 0.0
        fig.set_size_inches(WIDTH, machine + 0.9 + panel_height)
        if series:
            fig.get_layout_engine().set(h_pad=0.05)
            ax.get_gridspec().set_height_ratios((machine, panel_height))
    finish(ax, scale, has_play(model), adjustable="box")  # the limits hold every frame
    if load_scale is not None:
        ax.text(
            0.99,
            0.99,
            f"load bars: {largest:.4g} N = {LOAD_BAR:g} outer raceway radius",
            transform=ax.transAxes,
            fontsize=7,
            color="C3",
            ha="right",
            va="top",
        )
    title = ax.set_title("", fontsize=9)
    marker = _panel(panel_ax, ts, indices, series, ylabel)

    def update(n: int):
        i = indices[n]
        scene.update(frame_at(i))
        title.set_text(f"t = {ts[i]:.6g} s")
        if marker is not None:
            marker.set_xdata([ts[i], ts[i]])

    update(0)
    # every frame has the same limits, ticks and panel: lay the figure out once, not per frame
    fig.draw_without_rendering()
    fig.set_layout_engine(None)  # the positions stay; with "none" each print draws twice
    anim = FuncAnimation(fig, update, frames=len(indices), interval=1000.0 / fps, repeat=True)
    if path is not None:
        save(anim, path, writer, dpi)
    return anim


def _fix_limits(ax, scene: Scene, frames: list[Frame]) -> float:
    """Axes limits that hold the machine in every frame, 5 % to spare, at least `MIN_ASPECT`
    as high as wide; returns their height over their width."""
    boxes = []
    for frame in frames:
        scene.update(frame)
        ax.relim()
        boxes.append(ax.dataLim.get_points())
    lower = np.min([b[0] for b in boxes], axis=0)
    upper = np.max([b[1] for b in boxes], axis=0)
    spare = 0.05 * max(float(np.max(upper - lower)), 1e-9)
    lower, upper = lower - spare, upper + spare
    width, height = upper - lower
    if height < MIN_ASPECT * width:
        middle = 0.5 * (lower[1] + upper[1])
        lower[1], upper[1] = middle - 0.5 * MIN_ASPECT * width, middle + 0.5 * MIN_ASPECT * width
    ax.set_xlim(lower[0], upper[0])
    ax.set_ylim(lower[1], upper[1])
    return float((upper[1] - lower[1]) / (upper[0] - lower[0]))


def _panel(ax, ts, indices, series, ylabel: str):
    """The panel's curves over the frames' span and its time marker (None without a panel)."""
    if ax is None:
        return None
    span = slice(indices[0], indices[-1] + 1)
    for label, values in series.items():
        ax.plot(ts[span], values[span], lw=0.9, label=label or None)
    if any(series):
        ax.legend(fontsize=7, loc="upper left")
    ax.set_xlim(
        ts[indices[0]], ts[indices[-1]] if indices[-1] > indices[0] else ts[indices[0]] + 1.0
    )
    ax.set_xlabel("time t [s]")
    ax.set_ylabel(ylabel)
    ax.grid(True, linewidth=0.3, alpha=0.5)
    return ax.axvline(ts[indices[0]], color="k", lw=0.8)


def writer_for(path, fps: float):
    """The matplotlib writer of a file named ``path``: Pillow for ``.gif``, else ffmpeg; a
    ValueError where ffmpeg is needed and not on the PATH."""
    from matplotlib.animation import FFMpegWriter, PillowWriter

    path = Path(path)
    if path.suffix.lower() == ".gif":
        return PillowWriter(fps=fps)
    if FFMpegWriter.isAvailable():
        return FFMpegWriter(fps=fps)
    raise ValueError(
        f"Writing {path.name!r} needs ffmpeg, which is not on the PATH; write a .gif "
        "(Pillow, which comes with matplotlib) or install ffmpeg."
    )


def save(anim, path, writer, dpi: float) -> Path:
    """Write ``anim`` to ``path`` with ``writer`` (`writer_for`), atomically
    (`jaxbearing._files`)."""
    path = Path(path)
    with tempfile.TemporaryDirectory() as folder:  # the writers name the format by the suffix
        scratch = Path(folder) / f"animation{path.suffix}"
        anim.save(scratch, writer=writer, dpi=dpi)
        _files.write_bytes(path, scratch.read_bytes())
    return path
