"""``wbc campaign run|report``: many physics trials (push maps, Monte-Carlo robustness, gain sweeps), serially or
on Ray, streamed to a Parquet results folder, resumable (:mod:`wbc.campaign`).

    wbc campaign run --kind push --trials 1000 --results results/push --ray
    wbc campaign run my_campaign.toml --results results/mine --set scenario.steps=6 --set factors.force=[300,500]
    wbc campaign report results/push

Exit code 0 when the campaign ran (whatever its survival rate), 2 on bad input, 130 when interrupted (every
finished trial is recorded; run the same command again to resume).
"""

from __future__ import annotations

import math
import sys
import tomllib
from pathlib import Path

__all__ = ["register", "cmd_campaign"]


def register(subparsers, add_outputs=None) -> None:
    """Add the ``campaign`` sub-command (``run``, ``report``)."""
    from wbc.campaign.spec import KINDS

    p = subparsers.add_parser(
        "campaign", help="many physics trials (push maps, robustness, gain sweeps), serial or on Ray, to Parquet",
        description="Campaigns of closed-loop physics walks: each trial a pure function of (seed, index), rows "
                    "streamed to a Parquet folder as trials finish, resumable; survival with Wilson 95 % "
                    "intervals and plots.")
    sub = p.add_subparsers(dest="campaign_command", required=True)
    r = sub.add_parser("run", help="run (or resume) a campaign",
                       description="Run a campaign from a TOML file or --kind, recording one row per trial in --results; "
                                   "trials already there are skipped (resume).")
    r.add_argument("spec", nargs="?", type=Path, help="campaign TOML file (see wbc.campaign.spec); or use --kind")
    r.add_argument("--kind", choices=KINDS, default=None, help="a default campaign of this kind (no TOML file)")
    r.add_argument("--trials", type=int, default=None, help="number of trials (not for a sweep: points × repeats)")
    r.add_argument("--seed", type=int, default=None, help="campaign seed (default 0)")
    r.add_argument("--robot", default=None, help="scenario.robot (catalog name)")
    r.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override a spec entry, VALUE in TOML syntax, e.g. scenario.steps=6, factors.force=[300,500]")
    r.add_argument("--results", type=Path, required=True, metavar="DIR",
                   help="results folder: Parquet rows, plots (created; reused to resume)")
    r.add_argument("--ray", action="store_true",
                   help="run on a local Ray started on this machine's cores, confined to 127.0.0.1 (a private "
                        "network namespace whose only interface is lo)")
    r.add_argument("--workers", type=int, default=None, help="local Ray worker processes (default: all cores)")
    r.add_argument("--ray-address", default=None, metavar="HOST:PORT", help="join an existing Ray cluster")
    r.add_argument("--rerun-errors", action="store_true",
                   help="also run again the trials recorded as the trial function's exception (after fixing its "
                        "cause); trials the executor lost are always run again")
    r.add_argument("--no-plots", action="store_true", help="do not write OUT/plots/*.png at the end")
    r.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")
    r.set_defaults(func=cmd_campaign)
    rep = sub.add_parser("report", help="survival rates and plots of a results folder",
                         description="Print the survival rate with its Wilson 95 % interval, overall and per factor, "
                                     "and (re)make the plots of a campaign's results folder.")
    rep.add_argument("results", type=Path, help="campaign results folder (or a Parquet file)")
    rep.add_argument("--plots", type=Path, default=None, help="plot folder (default RESULTS/plots)")
    rep.add_argument("--metric", default=None,
                     help="a sweep's per-point metric for its heat map and best region: a max_… (lower is better) "
                          "or min_… (higher is better) column (default max_dcm_error_m)")
    rep.add_argument("--tolerance", type=float, default=None,
                     help="a sweep's best region: the points with the highest survival rate whose metric is within "
                          "this fraction of the best of them (default 0.05)")
    rep.add_argument("--nominal", type=Path, default=None, metavar="LOG",
                     help="a push campaign's denominator: the log of its walk without a push (wbc sim walk --steps "
                          "S --step-length L --step-duration T --log LOG, the campaign's scenario); prints the "
                          "survival on the pushes the LIPM can capture, per number of steps and direction octant, "
                          "and plots them (wbc.campaign.capture)")
    rep.set_defaults(func=cmd_campaign)


def _spec(args):
    from wbc.campaign.spec import default_spec, load_spec
    from wbc.exceptions import InvalidInputError

    if args.spec is not None and args.kind is not None:
        raise InvalidInputError("give a campaign TOML file or --kind, not both")
    if args.spec is None and args.kind is None:
        raise InvalidInputError("give a campaign TOML file or --kind push|robustness|sweep")
    if args.spec is not None:
        if not args.spec.is_file():
            raise InvalidInputError(f"campaign file {args.spec} does not exist")
        d = load_spec(args.spec).as_dict()
    else:
        d = default_spec(args.kind).as_dict()
    for item in args.set:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise InvalidInputError(f"--set {item!r}: expected KEY=VALUE (e.g. scenario.steps=6)")
        try:
            val = tomllib.loads(f"v = {value}")["v"]
        except tomllib.TOMLDecodeError:
            val = value  # a bare word: a string
        node = d
        parts = key.split(".")
        for part in parts[:-1]:
            node = node.setdefault(part, {})
            if not isinstance(node, dict):
                raise InvalidInputError(f"--set {key}: {part} is not a table")
        node[parts[-1]] = val
    if args.trials is not None:
        d["trials"] = args.trials
    if args.seed is not None:
        d["seed"] = args.seed
    if args.robot is not None:
        d.setdefault("scenario", {})["robot"] = args.robot
    if d.get("kind") == "sweep" and args.trials is None:
        d.pop("trials", None)
    _check_push_forces(d)
    return load_spec(d)


def _capture_report(args, table, plots: Path) -> None:
    """``--nominal``: the survival on the capturable pushes (:mod:`wbc.campaign.capture`) and its plot."""
    import json

    from wbc.campaign.capture import (capture_model, capture_summary, format_capture_report, load_nominal,
                                      plot_capture_map, push_capturability)
    from wbc.campaign.trials import cached_robot
    from wbc.exceptions import InvalidInputError

    meta = Path(args.results) / "campaign.json"
    if not meta.is_file():
        raise InvalidInputError(f"--nominal needs the campaign's spec: {meta} does not exist")
    scenario = json.loads(meta.read_text()).get("scenario", {})
    robot = cached_robot(scenario.get("robot", "talos"))
    nominal = load_nominal(args.nominal)
    model = capture_model(robot, nominal, float(scenario.get("step_duration", 0.6)))
    capture = push_capturability(table, nominal, model, robot)
    print(f"LIPM: ω = {model.omega:.3f} 1/s (z0 = {model.com_height:.3f} m), ℓ_max = {model.step_max:.3f} m, "
          f"step time {model.step_time:.3f} s, swing {model.swing_time:.3f} s, sole {model.sole_length:.3f} × "
          f"{model.sole_width:.3f} m")
    print(format_capture_report(capture_summary(table, capture)))
    print(f"plot written to {plot_capture_map(table, capture, plots / 'capture_map.png', model)}")


def _largest(factor, default: float) -> float | None:
    """The largest value a campaign factor (a number, ``[lo, hi]`` or ``{"values": [...]}``) can take; None when it
    is not made of finite numbers (the spec's own checks name that)."""
    if factor is None:
        return default
    values = factor.get("values") if isinstance(factor, dict) else factor
    values = values if isinstance(values, (list, tuple)) else [values]
    if not values or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
                             for v in values):
        return None
    return float(max(values))


def _check_push_forces(d: dict) -> None:
    """Refuse a campaign (its spec as a mapping, before the spec's own range checks) whose pushes go beyond what a
    trial can mean (:func:`wbc.cli.sim.push_force_limit`): the largest force of ``factors.force`` for the longest
    ``factors.push_duration``, against the robot's bound in the most favourable push direction (every 15 deg),
    before any trial runs.

    Raises:
        InvalidInputError: naming the force, the duration and the largest accepted force.
    """
    from wbc.campaign.trials import cached_robot
    from wbc.cli.sim import TRIAL_LIMIT_IN_CAPTURE_BOUNDS, push_force_limit
    from wbc.exceptions import InvalidInputError

    factors = d.get("factors")
    if not isinstance(factors, dict) or "force" not in factors:
        return
    force = _largest(factors["force"], 0.0)
    duration = _largest(factors.get("push_duration"), 0.1)
    robot_name = (d.get("scenario") or {}).get("robot", "talos")
    if force is None or duration is None or force <= 0 or duration <= 0 or not isinstance(robot_name, str):
        return
    robot = cached_robot(robot_name)
    limit, bound = push_force_limit(robot, duration, range(0, 360, 15))
    if force > limit:
        raise InvalidInputError(
            f"factors.force up to {force:g} N for {duration:g} s is beyond what a trial can mean (valid: <= "
            f"{math.floor(limit):.0f} N, {TRIAL_LIMIT_IN_CAPTURE_BOUNDS:g} × {robot.name}'s largest capture-point "
            f"bound of {bound:.0f} N over push directions for a {duration:g} s push, beyond which it falls whatever "
            "the controller does)")


def cmd_campaign(args) -> int:
    """Run ``wbc campaign run`` or ``wbc campaign report`` (module docstring). Returns the exit code."""
    from wbc.exceptions import InvalidInputError

    if args.campaign_command == "report":
        import math

        from wbc.campaign import format_report, make_plots, read_results
        from wbc.campaign.report import SWEEP_METRIC, SWEEP_TOLERANCE, format_sweep_region, metric_lower_is_better

        tolerance = SWEEP_TOLERANCE if args.tolerance is None else args.tolerance
        if not (math.isfinite(tolerance) and tolerance >= 0):
            raise InvalidInputError(f"--tolerance must be a finite fraction ≥ 0, got {args.tolerance}")
        if args.metric is not None:
            metric_lower_is_better(args.metric)
        table = read_results(args.results)
        if args.metric is not None and args.metric not in table.column_names:
            raise InvalidInputError(f"--metric {args.metric}: no such column in the results")
        meta = Path(args.results) / "campaign.json"
        sweep = None
        if meta.is_file():
            import json

            sweep = sorted(json.loads(meta.read_text()).get("sweep", {}).get("params", {})) or None
        print(format_report(table))
        metric = args.metric or (SWEEP_METRIC if SWEEP_METRIC in table.column_names else None)
        if sweep is not None and len(sweep) == 2 and metric is not None:
            print(format_sweep_region(table, sweep, metric, tolerance))
        plots = args.plots if args.plots is not None else Path(args.results) / "plots"
        for path in make_plots(table, plots, sweep_params=sweep, sweep_metric=args.metric, tolerance=tolerance):
            print(f"plot written to {path}")
        if args.nominal is not None:
            _capture_report(args, table, plots)
        return 0
    if args.workers is not None and args.workers < 1:
        raise InvalidInputError(f"--workers must be ≥ 1, got {args.workers}")
    if args.ray_address is not None and args.ray:
        raise InvalidInputError("--ray starts a local Ray; --ray-address joins one: give one of them")
    if args.workers is not None and not args.ray:
        raise InvalidInputError("--workers only applies with --ray")
    spec = _spec(args)
    from wbc.campaign import (RayExecutor, SerialExecutor, format_report, make_plots, run, summarize_campaign)
    from wbc.campaign.report import SWEEP_METRIC, format_sweep_region
    from wbc.campaign.store import ResultStore

    ResultStore(args.results, spec.as_dict())  # refuse a bad or foreign folder before starting anything
    if args.ray or args.ray_address:
        executor = RayExecutor(args.ray_address, workers=args.workers)
    else:
        executor = SerialExecutor()
    try:
        table = run(spec, args.results, executor=executor, progress=not args.no_progress,
                    rerun_errors=args.rerun_errors)
    except KeyboardInterrupt:
        from wbc.cli.output import sigterm_received

        store = ResultStore(args.results, spec.as_dict())
        n = len(store.done())
        store.close()
        # a SIGTERM that came inside a callback (numba's compiler) surfaces here as KeyboardInterrupt too
        how, code = ("terminated (SIGTERM)", 143) if sigterm_received() else ("interrupted", 130)
        print(f"wbc campaign: {how}; {n} of {spec.trials} trials finished in {args.results} "
              "(run the same command again to resume)", file=sys.stderr)
        return code
    print(format_report(table))
    sweep = sorted(spec.sweep["params"]) if spec.sweep else None
    if sweep is not None and len(sweep) == 2 and SWEEP_METRIC in table.column_names:
        print(format_sweep_region(table, sweep))
    s = summarize_campaign(table)
    print(f"results: {args.results}/trials ({table.num_rows} rows of {spec.trials}; executor {executor.name}, "
          f"{executor.workers} worker(s)); errors {s['errors']}")
    if not args.no_plots:
        for path in make_plots(table, Path(args.results) / "plots", sweep_params=sweep):
            print(f"plot written to {path}")
    return 0
