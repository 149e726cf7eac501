"""wbc.viz.progress: the bar follows simulated time on a terminal, is silent elsewhere, and forwards updates."""

from __future__ import annotations

import io

from wbc.viz.progress import ProgressViewer


class _Tty(io.StringIO):
    def isatty(self):
        return True


class _Inner:
    def __init__(self):
        self.calls, self.closed = [], False

    def update(self, q, t, overlays=None):
        self.calls.append((t, overlays))

    def close(self):
        self.closed = True


def test_bar_on_a_terminal_reaches_the_total():
    stream, inner = _Tty(), _Inner()
    p = ProgressViewer(2.0, inner, desc="run", stream=stream, delay=0.0, step=0.05)
    for k in range(1, 1001):
        p.update(None, k * 0.002, overlays={"com": k})
    assert abs(p.bar.n - 2.0) < 0.05
    p.bar.refresh()
    text = stream.getvalue()
    assert "run" in text and "2.00 s sim" in text
    assert len(inner.calls) == 1000 and inner.calls[-1] == (2.0, {"com": 1000})  # every tick forwarded
    p.close()
    assert inner.closed


def test_silent_when_not_a_terminal_or_disabled():
    for kwargs in ({"stream": io.StringIO()}, {"stream": _Tty(), "enabled": False}):
        p = ProgressViewer(1.0, delay=0.0, **kwargs)
        for k in range(1, 501):
            p.update(None, k * 0.002)
        p.close()
        assert kwargs["stream"].getvalue() == ""


def test_heartbeat_redraws_the_bar_before_the_first_tick_and_stops_after():
    """With a heartbeat (first run: kernels compiling before the first tick) the bar is redrawn with its elapsed
    time before any update; after the first update the heartbeat stops (only update() draws)."""
    import time

    stream = _Tty()
    p = ProgressViewer(10.0, desc="run", stream=stream, delay=0.0, heartbeat=0.2)
    deadline = time.monotonic() + 30.0
    while stream.getvalue().count("0.00/10.00 s sim") < 2 and time.monotonic() < deadline:
        time.sleep(0.05)
    assert stream.getvalue().count("0.00/10.00 s sim") >= 2, stream.getvalue()  # drawn repeatedly, at 0 s sim
    p.update(None, 1.0)
    time.sleep(0.6)  # three heartbeat periods
    drawn = stream.getvalue()
    time.sleep(0.6)
    assert stream.getvalue() == drawn  # no redraw without an update once the run has started
    p.close()

    quiet = _Tty()
    p = ProgressViewer(10.0, stream=quiet, delay=0.0, heartbeat=None)
    time.sleep(0.5)
    assert quiet.getvalue().count("s sim") <= 1  # at most tqdm's own first draw
    p.close()


def test_update_raises_keyboard_interrupt_once_interrupted():
    """`interrupted()` True (a Ctrl-C swallowed where it landed): the next update raises before forwarding."""
    import pytest

    flag, inner = [False], _Inner()
    p = ProgressViewer(1.0, inner, enabled=False, interrupted=lambda: flag[0])
    p.update(None, 0.002)
    flag[0] = True
    with pytest.raises(KeyboardInterrupt):
        p.update(None, 0.004)
    assert [t for t, _ in inner.calls] == [0.002]
    p.close()
