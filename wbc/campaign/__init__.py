"""Campaigns: thousands of closed-loop trials — push maps, Monte-Carlo robustness to plant ≠ model, gain sweeps —
run serially or on Ray, streamed to Parquet, resumable, reported with Wilson intervals.

    from wbc.campaign import default_spec, run, RayExecutor
    spec = default_spec("push", trials=100, scenario={"robot": "talos", "steps": 6})
    table = run(spec, "results/push", executor=RayExecutor())     # or the default SerialExecutor()

Modules: :mod:`~wbc.campaign.spec` (the campaign and its trial parameters), :mod:`~wbc.campaign.trials` (the
built-in physics-walk trial), :mod:`~wbc.campaign.executors` (serial / Ray), :mod:`~wbc.campaign.store` (the
Parquet results folder), :mod:`~wbc.campaign.report` (statistics and plots).
"""

from __future__ import annotations

import signal
import sys
import threading

from wbc.campaign.executors import RayExecutor, SerialExecutor
from wbc.campaign.report import format_report, make_plots, summarize_campaign, wilson_interval
from wbc.campaign.spec import CampaignSpec, default_spec, load_spec, trial_params
from wbc.campaign.store import ResultStore, is_finished, read_results
from wbc.campaign.trials import STOP_REQUESTED, walk_trial

__all__ = ["run", "CampaignSpec", "default_spec", "load_spec", "trial_params", "SerialExecutor", "RayExecutor",
           "read_results", "format_report", "make_plots", "summarize_campaign", "wilson_interval", "walk_trial"]


def run(spec, out, *, executor=None, trial_fn=None, progress: bool = True, indices=None,
        rerun_errors: bool = False):
    """Run the campaign's unfinished trials and record each row in ``out`` as it finishes.

    Resume: the trials with a finished row in ``out`` are skipped; the others — never run, or lost by the executor
    (:mod:`wbc.campaign.store`) — are run. A trial whose function raised is finished (its exception is its result:
    the trial is a pure function of (seed, index), so a rerun would raise again) and is skipped unless
    ``rerun_errors``.

    Interrupt: while it runs in the main thread, a SIGINT (Ctrl-C) is noted before the handler in place raises
    KeyboardInterrupt; from then on no row is recorded — not even one the trial function returned after catching the
    interrupt (as an error, or cut short) — so every trial the interrupt touched is run again on resume.

    Args:
        spec: a :class:`CampaignSpec`, a mapping or a TOML path (:func:`load_spec`).
        out: results folder (:mod:`wbc.campaign.store`).
        executor: :class:`SerialExecutor` (default) or :class:`RayExecutor`.
        trial_fn: ``fn(spec, params) -> dict`` of scalars (default :func:`walk_trial`); must be importable by the
            workers (a module-level function) when run on Ray.
        progress: a progress bar with ETA on stderr.
        indices: run only these trial indices (default all ``range(spec.trials)``).
        rerun_errors: also run again the trials whose recorded row is the trial function's exception.

    Returns:
        The results table (``pyarrow.Table``, one row per recorded trial, sorted by ``trial``).

    Raises:
        InvalidInputError: a bad spec, output folder (one holding another campaign, or in use by another
            process's campaign: the folder is locked while ``run`` runs, :mod:`wbc.campaign.store`), or executor.
        KeyboardInterrupt: passed on after the executor is closed; every finished trial is already recorded.
    """
    if not isinstance(spec, CampaignSpec):
        spec = load_spec(spec)
    store = ResultStore(out, spec.as_dict())
    executor = SerialExecutor() if executor is None else executor
    fn = walk_trial if trial_fn is None else trial_fn
    done = store.done(rerun_errors=rerun_errors)
    wanted = range(spec.trials) if indices is None else [int(i) for i in indices]
    todo = [i for i in wanted if i not in done]
    bar = None
    if progress and todo:
        from tqdm import tqdm

        bar = tqdm(total=len(wanted), initial=len(wanted) - len(todo), unit="trial", file=sys.stderr,
                   desc=f"campaign {spec.kind} ({executor.name})", dynamic_ncols=True)
    finished = set(done)
    watch = _InterruptWatch()
    try:
        with watch:
            for i, row in executor.map(fn, spec, todo):
                if watch.seen_any:  # this trial may have been cut short by the signal: not recorded, rerun on resume
                    watch.raise_again()
                if i in finished:  # never counted twice
                    continue
                store.append(row)
                if is_finished(row):
                    finished.add(i)
                if bar is not None:
                    bar.update(1)
    finally:
        if bar is not None:
            bar.close()
        executor.close()
        if not all(i in finished for i in range(spec.trials)):
            store.close()
    if all(i in finished for i in range(spec.trials)):
        try:
            store.compact()
        finally:
            store.close()
    return read_results(out)


class _InterruptWatch:
    """Notes a SIGINT or SIGTERM received while active (main thread only), then hands it to the handler that was in
    place (Python's default SIGINT handler raises KeyboardInterrupt). A signal ignored or left to the system is left
    alone. A handler that did not raise (a command's handler inside a C callback, where an exception would be
    swallowed) is called again by :meth:`raise_again` between two trials."""

    _SIGNALS = (signal.SIGINT, signal.SIGTERM)

    def __init__(self):
        self.seen = None
        self._previous: dict = {}

    @property
    def seen_any(self) -> bool:
        return self.seen is not None

    def _on_signal(self, signum, frame):
        self.seen = signum
        STOP_REQUESTED.set()
        self._previous[signum](signum, frame)

    def raise_again(self) -> None:
        """Call the handler of the signal seen again, outside any callback (it raises: KeyboardInterrupt for a
        SIGINT; a SIGTERM handler's own exception); KeyboardInterrupt if it does not."""
        handler = self._previous.get(self.seen)
        if handler is not None:
            handler(self.seen, None)
        raise KeyboardInterrupt

    def __enter__(self):
        STOP_REQUESTED.clear()
        if threading.current_thread() is threading.main_thread():
            for n in self._SIGNALS:
                previous = signal.getsignal(n)
                if callable(previous):
                    self._previous[n] = previous
                    signal.signal(n, self._on_signal)
        return self

    def __exit__(self, *exc):
        for n, previous in self._previous.items():
            signal.signal(n, previous)
        self._previous = {}
        return False
