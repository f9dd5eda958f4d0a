"""A progress bar for one long simulation, without touching the core's loop.

The core's run releases the GIL and writes its samples as it goes (``count``), so a Python thread
can watch it: every 0.1 s it reads how many samples exist and the time of the last one.  The loop pays
nothing and its numbers stay bit-identical with or without a bar.

``progress=None`` (default): a tqdm bar on stderr when stderr is a terminal, shown only if the run lasts
more than a second; ``True``/``False``: force it on or off; a callable ``progress(t_reached, duration)``
is called from the watching thread as the run advances (for programs), and once more at the end.
"""

import importlib
import sys
import threading

from ..errors import InputError

POLL_S = 0.1
DELAY_S = 1.0  # a bar appears only for runs longer than this (tqdm's ``delay``)


def check(progress):
    if progress is None or isinstance(progress, bool) or callable(progress):
        return progress
    raise InputError(f"progress: expected None, True, False or a callable progress(t, duration), got {progress!r}")


class Watch:
    """Context manager for one run of problem p over ``duration`` seconds (simulated)."""

    def __init__(self, progress, duration, p, desc="simulate"):
        self.callback = progress if callable(progress) and not isinstance(progress, bool) else None
        show = progress is True or (progress is None and sys.stderr.isatty())
        self.bar = None
        if show and self.callback is None and duration > 0:
            tqdm = importlib.import_module("tqdm.auto").tqdm  # only when a bar is shown
            self.bar = tqdm(total=duration, desc=desc, unit="s", delay=0 if progress is True else DELAY_S,
                            leave=False, bar_format="{l_bar}{bar}| {n:.3g}/{total:.3g} s simulated [{elapsed}<{remaining}]")
        self.p, self.duration = p, duration
        self.stop = threading.Event()
        self.thread = None
        self.reached = 0.0

    @property
    def active(self):
        return self.bar is not None or self.callback is not None

    def _poll(self):
        count = int(self.p.count[0])
        if count == 0:
            return
        t = float(self.p.out_t[count - 1])
        if t > self.reached:
            if self.bar is not None:
                self.bar.update(t - self.reached)
            self.reached = t
            if self.callback is not None:
                self.callback(t, self.duration)

    def _loop(self):
        while not self.stop.wait(POLL_S):
            self._poll()

    def __enter__(self):
        if self.active:
            self.thread = threading.Thread(target=self._loop, name="dynamics-progress", daemon=True)
            self.thread.start()
        return self

    def __exit__(self, *exc):
        if self.thread is not None:
            self.stop.set()
            self.thread.join()
            self._poll()
        if self.bar is not None:
            self.bar.close()
        return False


def watcher(progress, duration):
    """``watch`` argument of :func:`.run.run`: None when nothing would be shown (no thread at all)."""
    callback = callable(progress) and not isinstance(progress, bool)
    if not (callback or progress is True or (progress is None and sys.stderr.isatty())) or duration <= 0:
        return None
    return lambda p: Watch(progress, duration, p)
