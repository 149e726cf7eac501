"""A progress bar (tqdm, on stderr) fed through the ``viewer`` hook of the run loops.

The walk, balance and simulation loops call ``viewer.update(q, t, ...)`` once per tick; :class:`ProgressViewer`
advances a bar by simulated time (at most every ``step`` s of simulated time, so a tick costs one float
comparison) and forwards every call to an optional inner viewer (a live meshcat view).
"""

from __future__ import annotations

import sys
from typing import Any, Callable, TextIO

__all__ = ["ProgressViewer"]


class ProgressViewer:
    """Progress of a run in simulated seconds; also forwards ``update``/``close`` to ``inner``.

    Args:
        total: simulated duration of the run (s), or None if unknown (the bar then counts up).
        inner: a viewer with ``update(q, t, ...)`` and ``close()`` (e.g. :class:`wbc.viz.LiveViewer`), or None.
        desc: label in front of the bar.
        enabled: show the bar; None: only when ``stream`` is a terminal.
        stream: where the bar is drawn (default ``sys.stderr``).
        delay: the bar appears only after this many wall-clock seconds (short runs stay silent).
        step: simulated seconds between bar refreshes.
        heartbeat: wall-clock seconds between redraws of the bar (its elapsed time) until the first ``update`` —
            for a run whose first tick waits on something slow (compiling kernels); None: no redraw before it.
        interrupted: a callable returning True once the run was asked to stop (a Ctrl-C that may have been
            swallowed where it landed); ``update`` then raises KeyboardInterrupt. None: not checked.

    Raises:
        KeyboardInterrupt: from ``update``, when ``interrupted()`` is True.
    """

    def __init__(self, total: float | None, inner: Any = None, *, desc: str = "", enabled: bool | None = None,
                 stream: TextIO | None = None, delay: float = 2.0, step: float = 0.05,
                 heartbeat: float | None = None, interrupted: Callable[[], bool] | None = None):
        from tqdm import tqdm

        stream = sys.stderr if stream is None else stream
        if enabled is None:
            enabled = bool(getattr(stream, "isatty", lambda: False)())
        self.inner = inner
        self.enabled = enabled
        self._interrupted = interrupted
        self._step = float(step)
        self._shown = 0.0
        self.bar = tqdm(total=None if total is None else round(float(total), 3), unit="s", desc=desc,
                        file=stream, disable=not enabled, delay=delay, leave=False,
                        bar_format="{desc} {percentage:3.0f}%|{bar}| {n:.2f}/{total:.2f} s sim [{elapsed}<{remaining}]"
                        if total is not None else "{desc} {n:.2f} s sim [{elapsed}]")
        self._beating = None
        if enabled and heartbeat is not None:
            import threading

            self._beating = threading.Event()
            threading.Thread(target=self._beat, args=(float(heartbeat), self._beating), daemon=True,
                             name="wbc-progress-heartbeat").start()

    def _beat(self, period: float, stop) -> None:
        while not stop.wait(period):
            self.bar.refresh()

    def _stop_beat(self) -> None:
        if self._beating is not None:
            self._beating.set()
            self._beating = None

    def update(self, q, t: float | None = None, *args: Any, **kwargs: Any) -> None:
        """Forward to the inner viewer; advance the bar to simulated time ``t`` (s). Raises KeyboardInterrupt once
        ``interrupted()`` is True."""
        if self._interrupted is not None and self._interrupted():
            raise KeyboardInterrupt
        if self._beating is not None:
            self._stop_beat()
        if self.inner is not None:
            self.inner.update(q, t, *args, **kwargs)
        if t is not None and t - self._shown >= self._step:
            self.bar.update(t - self._shown)
            self._shown = t

    @property
    def reads_configuration(self) -> bool:
        """Whether :meth:`update` uses its ``q``: only to forward it to an inner viewer (one whose own
        ``reads_configuration`` is False, or absent, is taken at its word / as reading it)."""
        inner = self.inner
        return inner is not None and getattr(inner, "reads_configuration", True)

    def close(self) -> None:
        """Close the bar and the inner viewer."""
        self._stop_beat()
        self.bar.close()
        if self.inner is not None:
            self.inner.close()

    def __getattr__(self, name: str) -> Any:
        inner = self.__dict__.get("inner")
        if inner is None:
            raise AttributeError(name)
        return getattr(inner, name)
