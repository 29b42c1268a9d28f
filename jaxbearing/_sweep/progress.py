"""The sweep's progress display: a tqdm bar over chunks (`solve._progress.bar_class`: no
TqdmWarning in a notebook without ipywidgets), or plain lines without tqdm."""

from __future__ import annotations

from ..solve._progress import bar_class


class Progress:
    """A tqdm bar over chunks (already-done chunks counted at start), or plain lines; shows the
    rate in simulations per second of the chunks computed in this call."""

    def __init__(self, total, initial, enabled):
        self.total, self.count, self.enabled = total, initial, enabled
        self.bar = None
        self.points = 0
        self.seconds = 0.0
        if not enabled:
            return
        try:
            tqdm = bar_class()
        except ImportError:
            print(f"sweep: {initial}/{total} chunks done", flush=True)
            return
        self.bar = tqdm(total=total, initial=initial, unit="chunk", desc="sweep", dynamic_ncols=True)

    def update(self, points, seconds):
        self.count += 1
        self.points += points
        self.seconds += seconds
        if not self.enabled:
            return
        rate = self.points / self.seconds if self.seconds > 0 else float("nan")
        if self.bar is not None:
            self.bar.set_postfix_str(f"{rate:.2f} sim/s", refresh=False)
            self.bar.update(1)
        else:
            print(f"sweep: {self.count}/{self.total} chunks done ({rate:.2f} sim/s)", flush=True)

    def close(self):
        if self.bar is not None:
            self.bar.close()
