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

import sys

from wbc.campaign.executors import RayExecutor, SerialExecutor
from wbc.campaign.report import format_report, make_plots, summarize_campaign, wilson_interval
from wbc.campaign.spec import CampaignSpec, default_spec, load_spec, trial_params
from wbc.campaign.store import ResultStore, read_results
from wbc.campaign.trials import walk_trial

__all__ = ["run", "CampaignSpec", "default_spec", "load_spec", "trial_params", "SerialExecutor", "RayExecutor",
           "read_results", "format_report", "make_plots", "summarize_campaign", "wilson_interval", "walk_trial"]


def run(spec, out, *, executor=None, trial_fn=None, progress: bool = True, indices=None):
    """Run the campaign's unfinished trials and record each row in ``out`` as it finishes.

    Args:
        spec: a :class:`CampaignSpec`, a mapping or a TOML path (:func:`load_spec`).
        out: results folder (:mod:`wbc.campaign.store`); trials already recorded there are skipped (resume).
        executor: :class:`SerialExecutor` (default) or :class:`RayExecutor`.
        trial_fn: ``fn(spec, params) -> dict`` of scalars (default :func:`walk_trial`); must be importable by the
            workers (a module-level function) when run on Ray.
        progress: a progress bar with ETA on stderr.
        indices: run only these trial indices (default all ``range(spec.trials)``).

    Returns:
        The results table (``pyarrow.Table``, one row per recorded trial, sorted by ``trial``).

    Raises:
        InvalidInputError: a bad spec, output folder (or one holding another campaign), or executor.
        KeyboardInterrupt: passed on after the executor is closed; every finished trial is already recorded.
    """
    if not isinstance(spec, CampaignSpec):
        spec = load_spec(spec)
    store = ResultStore(out, spec.as_dict())
    executor = SerialExecutor() if executor is None else executor
    fn = walk_trial if trial_fn is None else trial_fn
    done = store.done()
    wanted = range(spec.trials) if indices is None else [int(i) for i in indices]
    todo = [i for i in wanted if i not in done]
    bar = None
    if progress and todo:
        from tqdm import tqdm

        bar = tqdm(total=len(wanted), initial=len(wanted) - len(todo), unit="trial", file=sys.stderr,
                   desc=f"campaign {spec.kind} ({executor.name})", dynamic_ncols=True)
    recorded = set(done)
    try:
        for i, row in executor.map(fn, spec, todo):
            if i in recorded:  # never counted twice
                continue
            store.append(row)
            recorded.add(i)
            if bar is not None:
                bar.update(1)
    finally:
        if bar is not None:
            bar.close()
        executor.close()
    if all(i in recorded for i in range(spec.trials)):
        store.compact()
    return read_results(out)
