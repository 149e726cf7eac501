"""Campaign statistics and plots: survival rates with Wilson score intervals, overall and per factor, the survival
map of push force against direction (and against gait phase), metric histograms, and for a sweep the survival per
point over its two parameters and a continuous metric's map with the best region marked (:func:`best_region`).

Wilson score interval (Wilson 1927, "Probable inference, the law of succession, and statistical inference", JASA
22(158); Agresti & Coull 1998, The American Statistician 52(2), eq. 2) for k successes in n trials at confidence
z (1.96 for 95 %), p̂ = k/n:

    centre = (p̂ + z²/2n) / (1 + z²/n),   half-width = z √(p̂(1 − p̂)/n + z²/4n²) / (1 + z²/n)

It stays inside [0, 1] and keeps its coverage for small n and p̂ near 0 or 1, where the normal approximation fails.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from wbc.campaign.spec import FACTOR_KEYS, SWEEP_KEYS
from wbc.campaign.store import finished_mask
from wbc.exceptions import InvalidInputError

__all__ = ["wilson_interval", "summarize_campaign", "factor_table", "make_plots", "format_report", "sweep_points",
           "best_region", "region_summary", "format_sweep_region", "metric_lower_is_better", "SWEEP_METRIC",
           "SWEEP_TOLERANCE", "pooled_survival", "pooled_region"]

#: A sweep's default metric for its heat map and best region (``walk_trial``'s peak DCM error, m; lower is better).
SWEEP_METRIC = "max_dcm_error_m"
#: Default tolerance of the best region, relative to the best value (:func:`best_region`).
SWEEP_TOLERANCE = 0.05
#: The columns that are trial parameters, not measured metrics: the factors (push, plant ≠ model) and the sweepable
#: options of :mod:`wbc.campaign.spec`, in that order (the report's "by …" tables).
TRIAL_PARAMS = (*FACTOR_KEYS, *SWEEP_KEYS)


def wilson_interval(k: int, n: int, z: float = 1.959963984540054) -> tuple[float, float]:
    """Wilson score interval (module docstring) of ``k`` successes in ``n`` trials.

    Returns:
        (low, high) in [0, 1]; (0, 1) when n = 0.

    Raises:
        InvalidInputError: k or n negative, k > n, z ≤ 0.
    """
    if n < 0 or k < 0 or k > n or not z > 0:
        raise InvalidInputError(f"wilson_interval needs 0 ≤ k ≤ n and z > 0, got k={k}, n={n}, z={z}")
    if n == 0:
        return 0.0, 1.0
    p = k / n
    z2 = z * z
    den = 1.0 + z2 / n
    centre = (p + z2 / (2 * n)) / den
    half = z * math.sqrt(p * (1 - p) / n + z2 / (4 * n * n)) / den
    return max(0.0, centre - half), min(1.0, centre + half)


def _rows(table) -> dict:
    return {name: np.array(table.column(name).to_pylist(), dtype=object) for name in table.column_names}


def summarize_campaign(table) -> dict:
    """Overall outcome counts of a results table (:func:`wbc.campaign.store.read_results`).

    Returns:
        ``{"trials", "survived", "fell", "failed", "errors", "lost", "survival_rate", "wilson95": (lo, hi),
        "fall_reasons": {reason: count}}``; ``errors`` counts every error row: the trials whose function raised and
        the ``lost`` ones, not finished (:mod:`wbc.campaign.store`; a resumed run runs them again). Errors are left
        out of the rate.
    """
    cols = _rows(table)
    outcome = cols.get("outcome", np.array([], dtype=object))
    n_err = int(np.sum(outcome == "error"))
    n_lost = int(len(outcome) - np.sum(finished_mask(table))) if len(outcome) else 0
    n_surv = int(np.sum(outcome == "survived"))
    n = len(outcome) - n_err
    reasons: dict = {}
    for r, o in zip(cols.get("fall_reason", [None] * len(outcome)), outcome):
        if o in ("fell", "failed"):
            key = _reason_kind(r)
            reasons[key] = reasons.get(key, 0) + 1
    lo, hi = wilson_interval(n_surv, n)
    return {"trials": len(outcome), "survived": n_surv, "fell": int(np.sum(outcome == "fell")),
            "failed": int(np.sum(outcome == "failed")), "errors": n_err, "lost": n_lost,
            "survival_rate": n_surv / n if n else float("nan"), "wilson95": (lo, hi), "fall_reasons": reasons}


def _reason_kind(reason) -> str:
    """The criterion of a fall reason, without the bodies or numbers it names."""
    r = str(reason or "unknown")
    return r.split(":")[0].strip()


def factor_table(table, factor: str, bins: int = 5) -> list[dict]:
    """Survival per bin of ``factor`` (equal-width bins over its range, or one bin per value for ≤ ``bins`` values).

    Returns:
        ``[{"lo", "hi", "n", "survived", "rate", "wilson95"}]`` per non-empty bin.

    Raises:
        InvalidInputError: the table has no column ``factor``.
    """
    cols = _rows(table)
    if factor not in cols:
        raise InvalidInputError(f"no column {factor!r} in the results (columns: {', '.join(sorted(cols))})")
    outcome = cols["outcome"]
    ok = outcome != "error"
    x = cols[factor][ok].astype(float)
    s = (outcome[ok] == "survived")
    if len(x) == 0:
        return []
    values = np.unique(x)
    if len(values) <= bins:
        edges = [(v, v) for v in values]
        member = [x == v for v in values]
    else:
        e = np.linspace(x.min(), x.max(), bins + 1)
        edges = list(zip(e[:-1], e[1:]))
        idx = np.clip(np.searchsorted(e, x, side="right") - 1, 0, bins - 1)
        member = [idx == b for b in range(bins)]
    out = []
    for (lo, hi), m in zip(edges, member):
        n, k = int(m.sum()), int(s[m].sum())
        if n:
            out.append({"lo": float(lo), "hi": float(hi), "n": n, "survived": k, "rate": k / n,
                        "wilson95": wilson_interval(k, n)})
    return out


def format_report(table, factors=None) -> str:
    """The campaign's text report: overall survival with its Wilson 95 % interval, fall criteria, per factor (and per
    swept parameter: a sweep's points pooled in bins of one gain)."""
    s = summarize_campaign(table)
    lo, hi = s["wilson95"]
    lost = f" (of which {s['lost']} lost by the executor, not finished: rerun on resume)" if s["lost"] else ""
    lines = [f"trials {s['trials']}: survived {s['survived']}, fell {s['fell']}, failed otherwise {s['failed']}, "
             f"errors {s['errors']}{lost}",
             f"survival rate {s['survival_rate']:.3f} (Wilson 95 % interval {lo:.3f} – {hi:.3f})"]
    if s["fall_reasons"]:
        lines.append("what ended the failed trials: " + ", ".join(f"{k} ×{v}" for k, v in
                                                                 sorted(s["fall_reasons"].items())))
    if factors is None:
        factors = [f for f in TRIAL_PARAMS if f in table.column_names]
    for f in factors:
        rows = factor_table(table, f)
        if len({(r["lo"], r["hi"]) for r in rows}) <= 1:
            continue
        lines.append(f"by {f}:")
        for r in rows:
            a, b = r["wilson95"]
            span = f"{r['lo']:.4g}" if r["lo"] == r["hi"] else f"{r['lo']:.4g} – {r['hi']:.4g}"
            lines.append(f"  {span:>20}: {r['survived']:4d}/{r['n']:<4d} = {r['rate']:.2f}  [{a:.2f}, {b:.2f}]")
    return "\n".join(lines)


def make_plots(table, out_dir, *, sweep_params=None, sweep_metric: str | None = None,
               tolerance: float = SWEEP_TOLERANCE) -> list[Path]:
    """Write the campaign's PNG plots into ``out_dir`` (created): ``survival_map.png`` (force vs direction, and vs
    phase, when those columns vary), ``metrics.png`` (histograms of the numeric metrics, survivors vs the rest) and,
    for a sweep, ``sweep.png`` (survival rate per point over its two parameters, best points marked; on a grid also
    the survival pooled over each point's neighbourhood with its top decile outlined, :func:`pooled_region`) and
    ``sweep_metric.png`` (``sweep_metric`` per point as a heat map over the two parameters — one cell per point of a
    grid — with the best region of :func:`best_region` outlined and the points where a trial fell crossed).

    Args:
        table: results (:func:`wbc.campaign.store.read_results`).
        out_dir: plot folder.
        sweep_params: the sweep's two parameter names, or None (not a sweep).
        sweep_metric: the heat map's metric (``max_…`` or ``min_…`` column); None: :data:`SWEEP_METRIC` when the
            results have it (else no ``sweep_metric.png``).
        tolerance: the best region's tolerance (:func:`best_region`).

    Returns:
        The written paths.

    Raises:
        InvalidInputError: ``out_dir`` is a file or cannot be created; ``sweep_metric`` given but not a column, or
            named neither ``max_…`` nor ``min_…``; ``tolerance`` < 0.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir = Path(out_dir)
    if out_dir.exists() and not out_dir.is_dir():
        raise InvalidInputError(f"plot folder {out_dir} is a file")
    try:
        out_dir.mkdir(parents=True, exist_ok=True)
    except OSError as e:
        raise InvalidInputError(f"plot folder {out_dir}: cannot create it ({e.strerror or e})") from None
    cols = _rows(table)
    ok = cols["outcome"] != "error"
    surv = (cols["outcome"] == "survived")[ok]
    written = []

    def varies(name):
        return name in cols and len(np.unique(cols[name][ok].astype(float))) > 1

    panels = [p for p in (("direction_deg", "force"), ("phase", "force")) if varies(p[0]) and varies(p[1])]
    if panels:
        fig, axes = plt.subplots(1, len(panels), figsize=(6.5 * len(panels), 5), squeeze=False)
        for ax, (xname, yname) in zip(axes[0], panels):
            x, y = cols[xname][ok].astype(float), cols[yname][ok].astype(float)
            nx, ny = 12, 6
            H = np.full((ny, nx), np.nan)
            span = {"direction_deg": (0.0, 360.0), "phase": (0.0, 1.0)}[xname]  # the factor's whole range
            xe = np.linspace(min(span[0], x.min()), max(span[1], x.max()), nx + 1)
            ye = np.linspace(y.min(), y.max(), ny + 1)
            ix = np.clip(np.searchsorted(xe, x, side="right") - 1, 0, nx - 1)
            iy = np.clip(np.searchsorted(ye, y, side="right") - 1, 0, ny - 1)
            for a in range(ny):
                for b in range(nx):
                    m = (ix == b) & (iy == a)
                    if m.any():
                        H[a, b] = surv[m].mean()
            im = ax.pcolormesh(xe, ye, H, cmap="RdYlGn", vmin=0, vmax=1, alpha=0.55, shading="flat")
            ax.scatter(x[surv], y[surv], s=10, c="tab:green", edgecolors="k", linewidths=0.3, label="survived")
            ax.scatter(x[~surv], y[~surv], s=14, c="tab:red", marker="x", label="fell / failed")
            ax.set_xlim(xe[0], xe[-1])
            ax.set_xlabel({"direction_deg": "push direction (deg, 0 = forward, 90 = left)",
                           "phase": "push start (fraction of the walking steps)"}[xname])
            ax.set_ylabel("push force (N)")
            ax.legend(loc="upper right", fontsize=8)
            fig.colorbar(im, ax=ax, label="survival rate per cell")
        s = summarize_campaign(table)
        lo, hi = s["wilson95"]
        fig.suptitle(f"survival {s['survived']}/{s['trials'] - s['errors']} = {s['survival_rate']:.2f} "
                     f"(Wilson 95 %: {lo:.2f} – {hi:.2f})")
        fig.tight_layout()
        path = out_dir / "survival_map.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        written.append(path)
    skip = {"trial", "point", "repeat", "wall_s", "push_time_s"}
    metrics = [k for k in cols if k not in skip and _numeric(cols[k][ok]) and not varies_param(k)
               and len(np.unique(cols[k][ok].astype(float)[np.isfinite(cols[k][ok].astype(float))])) > 1]
    metrics = metrics[:9]
    if metrics:
        n = len(metrics)
        ncol = min(3, n)
        nrow = math.ceil(n / ncol)
        fig, axes = plt.subplots(nrow, ncol, figsize=(4.2 * ncol, 3.2 * nrow), squeeze=False)
        for ax, k in zip(axes.flat, metrics):
            v = cols[k][ok].astype(float)
            fin = np.isfinite(v)
            bins = np.histogram_bin_edges(v[fin], bins=20)
            ax.hist(v[fin & surv], bins=bins, alpha=0.7, color="tab:green", label="survived")
            ax.hist(v[fin & ~surv], bins=bins, alpha=0.7, color="tab:red", label="fell / failed")
            ax.set_title(k, fontsize=9)
        for ax in list(axes.flat)[n:]:
            ax.axis("off")
        axes.flat[0].legend(fontsize=7)
        fig.tight_layout()
        path = out_dir / "metrics.png"
        fig.savefig(path, dpi=100)
        plt.close(fig)
        written.append(path)
    if sweep_params and len(sweep_params) == 2 and "point" in cols:
        a, b = sweep_params
        pts = cols["point"][ok].astype(int)
        ids = np.unique(pts)
        xa = np.array([float(cols[a][ok][pts == p][0]) for p in ids])
        xb = np.array([float(cols[b][ok][pts == p][0]) for p in ids])
        rate = np.array([surv[pts == p].mean() for p in ids])
        nrep = np.array([(pts == p).sum() for p in ids])
        pooled = pooled_survival({a: xa, b: xb, "survived": (rate * nrep).round().astype(int), "n": nrep},
                                 sweep_params)
        fig, axes = plt.subplots(1, 1 if pooled is None else 2, figsize=(6.5 if pooled is None else 13.5, 5),
                                 squeeze=False)
        ax = axes[0, 0]
        sc = ax.scatter(xa, xb, c=rate, cmap="RdYlGn", vmin=0, vmax=1, s=60, edgecolors="k", linewidths=0.3)
        best = rate >= rate.max() - 1e-12
        ax.scatter(xa[best], xb[best], s=200, facecolors="none", edgecolors="b", linewidths=1.5,
                   label=f"best: {rate.max():.2f} over {int(nrep[best][0])} pushes ({best.sum()} points)")
        ax.set_xlabel(a)
        ax.set_ylabel(b)
        ax.legend(fontsize=8, loc="upper right")
        fig.colorbar(sc, ax=ax, label="survival rate (same pushes at every point)")
        if pooled is not None:
            from matplotlib.patches import Rectangle

            ax = axes[0, 1]
            ua, ub = np.unique(xa), np.unique(xb)
            ea, eb = _edges(ua), _edges(ub)
            ia, ib = np.searchsorted(ua, xa), np.searchsorted(ub, xb)
            grid = np.full((len(ub), len(ua)), np.nan)
            grid[ib, ia] = pooled[0] / np.maximum(pooled[1], 1)
            im = ax.pcolormesh(ea, eb, grid, cmap="RdYlGn", vmin=0, vmax=1, shading="flat")
            region = pooled_region({a: xa, b: xb, "survived": (rate * nrep).round().astype(int),
                                    "n": nrep}, sweep_params)
            for i in np.flatnonzero(region):
                ax.add_patch(Rectangle((ea[ia[i]], eb[ib[i]]), ea[ia[i] + 1] - ea[ia[i]], eb[ib[i] + 1] - eb[ib[i]],
                                       fill=False, edgecolor="b", linewidth=1.8))
            ax.plot([], [], "s", mfc="none", mec="b", label=f"top decile ({int(region.sum())} points)")
            ax.legend(fontsize=8, loc="upper right", framealpha=0.8)
            ax.set_xlabel(a)
            ax.set_ylabel(b)
            ax.set_title("survival pooled over each point's 3 × 3 grid neighbourhood", fontsize=9)
            fig.colorbar(im, ax=ax, label="pooled survival rate")
        fig.tight_layout()
        path = out_dir / "sweep.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        written.append(path)
        metric = sweep_metric if sweep_metric is not None else SWEEP_METRIC if SWEEP_METRIC in cols else None
        if metric is not None:
            lower = metric_lower_is_better(metric)
            pts = sweep_points(table, sweep_params, metric)
            region = best_region(pts, tolerance=tolerance, lower_is_better=lower)
            path = out_dir / "sweep_metric.png"
            _plot_sweep_metric(plt, pts, sweep_params, metric, region, lower, tolerance, path)
            written.append(path)
    return written


def metric_lower_is_better(metric: str) -> bool:
    """Direction of a metric from its name: ``max_…`` (a peak: error, slip, deviation) lower is better, ``min_…`` (a
    margin) higher is better.

    Raises:
        InvalidInputError: a name with neither prefix.
    """
    if metric.startswith("max_"):
        return True
    if metric.startswith("min_"):
        return False
    raise InvalidInputError(f"sweep metric {metric!r}: give a max_… (lower is better) or min_… (higher is better) "
                            "column of the results")


def sweep_points(table, params, metric: str = SWEEP_METRIC) -> dict:
    """Per point of a sweep: its two parameters, its finished trials and survivors, and ``metric`` averaged over its
    finished trials with a finite value.

    Args:
        table: results (:func:`wbc.campaign.store.read_results`) with columns ``point``, both params and ``metric``.
        params: the two swept parameter names (``[a, b]``).
        metric: a numeric column (default :data:`SWEEP_METRIC`), or None (``metric`` all NaN).

    Returns:
        ``{"point", a, b, "n", "survived", "rate", "metric"}``, arrays of shape (points,) in point order
        (``metric`` NaN where no trial of the point has a finite value).

    Raises:
        InvalidInputError: not two params, or a column missing (named, with the columns there are).
    """
    if len(params) != 2:
        raise InvalidInputError(f"a sweep map needs two swept parameters, got {list(params)}")
    cols = _rows(table)
    for name in ("point", "outcome", *params, *([metric] if metric is not None else [])):
        if name not in cols:
            raise InvalidInputError(f"no column {name!r} in the results (columns: {', '.join(sorted(cols))})")
    ok = cols["outcome"] != "error"
    pts = cols["point"][ok].astype(int)
    surv = cols["outcome"][ok] == "survived"
    m = (np.full(int(ok.sum()), np.nan) if metric is None else
         np.array([np.nan if v is None else float(v) for v in cols[metric][ok]], dtype=float))
    ids = np.unique(pts)
    out = {"point": ids}
    for name in params:
        v = cols[name][ok].astype(float)
        out[name] = np.array([v[pts == p][0] for p in ids])
    out["n"] = np.array([int((pts == p).sum()) for p in ids])
    out["survived"] = np.array([int(surv[pts == p].sum()) for p in ids])
    out["rate"] = out["survived"] / np.maximum(out["n"], 1)
    out["metric"] = np.array([np.nanmean(m[pts == p]) if np.isfinite(m[pts == p]).any() else np.nan for p in ids])
    return out


def best_region(points: dict, *, tolerance: float = SWEEP_TOLERANCE, lower_is_better: bool = True) -> np.ndarray:
    """The best region of a sweep (:func:`sweep_points`): among the points with the highest survival rate of the
    sweep (every trial survived, when any point did), those whose metric is within ``tolerance`` · |best| of the
    best such point's metric (``best`` the lowest value when ``lower_is_better``, else the highest).

    Returns:
        Boolean mask of shape (points,); all False when no point has a finite metric.

    Raises:
        InvalidInputError: ``tolerance`` negative or not finite.
    """
    if not (isinstance(tolerance, (int, float)) and math.isfinite(tolerance) and tolerance >= 0):
        raise InvalidInputError(f"best-region tolerance must be a finite number ≥ 0, got {tolerance!r}")
    m, rate = points["metric"], points["rate"]
    fin = np.isfinite(m)
    if not fin.any():
        return np.zeros(len(m), dtype=bool)
    eligible = fin & (rate >= rate[fin].max() - 1e-12)
    best = m[eligible].min() if lower_is_better else m[eligible].max()
    slack = tolerance * abs(best)
    within = m <= best + slack if lower_is_better else m >= best - slack
    return eligible & within


def pooled_survival(points: dict, params) -> tuple[np.ndarray, np.ndarray] | None:
    """Survival of each grid point pooled with its lattice neighbours: the trials of the points whose indices along
    both parameters differ from its own by at most one (its 3 × 3 neighbourhood, fewer at the edges).

    With few trials per point each point's survival is a coarse draw; pooling neighbouring gains trades resolution
    for trials (a box-kernel smoother of the survival indicator over the grid).

    Returns:
        ``(survived, trials)``, integer arrays of shape (points,); None when the points are not on a lattice.
    """
    a, b = params
    ua, ub = np.unique(points[a]), np.unique(points[b])
    if len(ua) * len(ub) > 2 * len(points[a]):
        return None
    ia, ib = np.searchsorted(ua, points[a]), np.searchsorted(ub, points[b])
    k, n = np.zeros(len(ia), dtype=int), np.zeros(len(ia), dtype=int)
    for i in range(len(ia)):
        near = (np.abs(ia - ia[i]) <= 1) & (np.abs(ib - ib[i]) <= 1)
        k[i], n[i] = points["survived"][near].sum(), points["n"][near].sum()
    return k, n


def pooled_region(points: dict, params, quantile: float = 0.9) -> np.ndarray | None:
    """Best region by pooled survival (:func:`pooled_survival`): the points whose pooled survival rate is at or
    above its ``quantile`` over the sweep's points (numpy's linear interpolation): the top decile by default. The
    region is selected on the trials it is then measured on, so its survival is an optimistic estimate; confirm it
    with new pushes.

    Returns:
        Boolean mask of shape (points,); None when the points are not on a lattice.
    """
    pooled = pooled_survival(points, params)
    if pooled is None:
        return None
    rate = pooled[0] / np.maximum(pooled[1], 1)
    return rate >= np.quantile(rate, quantile) - 1e-12


def region_summary(points: dict, region: np.ndarray, params, metric: str) -> dict:
    """Numbers of a best region (:func:`best_region`): ``{"points", "trials", "survived", "wilson95", <param>: (lo,
    hi), "metric": (lo, hi), "box_points", "box_survived_points"}`` — the box is the region's parameter ranges, and
    its counts say how many sweep points lie in it and how many of those had every trial survive."""
    a, b = params
    k, n = int(points["survived"][region].sum()), int(points["n"][region].sum())
    out = {"points": int(region.sum()), "trials": n, "survived": k, "wilson95": wilson_interval(k, n)}
    if not region.any():
        return out
    box = np.ones(len(region), dtype=bool)
    for name in params:
        v = points[name][region]
        out[name] = (float(v.min()), float(v.max()))
        box &= (points[name] >= v.min() - 1e-12) & (points[name] <= v.max() + 1e-12)
    out["metric"] = (float(points["metric"][region].min()), float(points["metric"][region].max()))
    out["box_points"] = int(box.sum())
    out["box_survived_points"] = int((box & (points["survived"] == points["n"])).sum())
    return out


def format_sweep_region(table, params, metric: str = SWEEP_METRIC, tolerance: float = SWEEP_TOLERANCE) -> str:
    """The best region (:func:`best_region`) of a sweep in words: its rule, parameter ranges, points, metric values
    and survival with its Wilson 95 % interval."""
    lower = metric_lower_is_better(metric)
    pts = sweep_points(table, params, metric)
    region = best_region(pts, tolerance=tolerance, lower_is_better=lower)
    s = region_summary(pts, region, params, metric)
    rule = (f"best region: the points with the sweep's highest survival rate ({pts['rate'].max():.2f}) whose "
            f"{metric} is within {100 * tolerance:g} % of the best of them ({'lowest' if lower else 'highest'})")
    if not s["points"]:
        return rule + ": none (no finite value)"
    a, b = params
    lo, hi = s["wilson95"]
    lines = _format_pooled(pts, params)
    return "\n".join([
        *lines,
        rule + ":",
        f"  {s['points']} points, {a} {s[a][0]:.4g} – {s[a][1]:.4g}, {b} {s[b][0]:.4g} – {s[b][1]:.4g}; "
        f"{metric} {s['metric'][0]:.4g} – {s['metric'][1]:.4g}",
        f"  survival {s['survived']}/{s['trials']} (Wilson 95 % interval {lo:.3f} – {hi:.3f}); its box holds "
        f"{s['box_points']} sweep points, {s['box_survived_points']} of them with every trial survived"])


def _format_pooled(pts: dict, params) -> list:
    region = pooled_region(pts, params)
    if region is None or not region.any():
        return []
    a, b = params
    k, n = pooled_survival(pts, params)
    rate = k / np.maximum(n, 1)
    ua, ub = np.unique(pts[a]), np.unique(pts[b])
    ia, ib = np.searchsorted(ua, pts[a]), np.searchsorted(ub, pts[b])
    near = np.zeros(len(region), dtype=bool)  # the trials the region's pooled rates rest on, each counted once
    for i in np.flatnonzero(region):
        near |= (np.abs(ia - ia[i]) <= 1) & (np.abs(ib - ib[i]) <= 1)
    kk, nn = int(pts["survived"][near].sum()), int(pts["n"][near].sum())
    lo, hi = wilson_interval(kk, nn)
    return [f"best region by survival pooled over each point's 3 × 3 grid neighbourhood (top decile, pooled rate "
            f"≥ {rate[region].min():.2f}): {int(region.sum())} points, {a} {pts[a][region].min():.4g} – "
            f"{pts[a][region].max():.4g}, {b} {pts[b][region].min():.4g} – {pts[b][region].max():.4g}; their "
            f"neighbourhoods' {int(near.sum())} points: survival {kk}/{nn} (Wilson 95 % interval {lo:.3f} – "
            f"{hi:.3f}; selected on these trials: optimistic)"]


def _plot_sweep_metric(plt, pts, params, metric, region, lower, tolerance, path) -> None:
    """Two heat maps of ``metric`` over the two parameters: every point on one colour scale (left), and the points
    with the sweep's highest survival rate on their own scale, the others grey (right); best region outlined."""
    from matplotlib.colors import ListedColormap
    from matplotlib.patches import Rectangle

    a, b = params
    xa, xb, m = pts[a], pts[b], pts["metric"]
    fell = pts["survived"] < pts["n"]
    fin = np.isfinite(m)
    top = fin & (pts["rate"] >= (pts["rate"][fin].max() if fin.any() else 0.0) - 1e-12)
    ua, ub = np.unique(xa), np.unique(xb)
    lattice = len(ua) * len(ub) <= 2 * len(xa)  # a grid: one cell per point
    cmap = "viridis_r" if lower else "viridis"
    better = "lower" if lower else "higher"
    fig, axes = plt.subplots(1, 2, figsize=(13.5, 5.5))
    for ax, shown, title in ((axes[0], np.ones(len(m), dtype=bool), f"{metric} per point, every point"),
                             (axes[1], top, f"{metric} of the points with the highest survival rate "
                                            f"({pts['rate'][top].max() if top.any() else 0:.2f}); others grey")):
        vals = np.where(shown, m, np.nan)
        if lattice:
            ea, eb = _edges(ua), _edges(ub)
            ia, ib = np.searchsorted(ua, xa), np.searchsorted(ub, xb)
            other = np.full((len(ub), len(ua)), np.nan)
            other[ib[~shown], ia[~shown]] = 1.0
            ax.pcolormesh(ea, eb, other, cmap=ListedColormap(["0.8"]), shading="flat")
            grid = np.full((len(ub), len(ua)), np.nan)
            grid[ib, ia] = vals
            im = ax.pcolormesh(ea, eb, grid, cmap=cmap, shading="flat")
            for i in np.flatnonzero(region):
                ax.add_patch(Rectangle((ea[ia[i]], eb[ib[i]]), ea[ia[i] + 1] - ea[ia[i]], eb[ib[i] + 1] - eb[ib[i]],
                                       fill=False, edgecolor="red", linewidth=1.8))
        else:  # random points
            ax.scatter(xa[~shown], xb[~shown], c="0.8", s=70)
            im = ax.scatter(xa[shown], xb[shown], c=m[shown], cmap=cmap, s=70)
            ax.scatter(xa[region], xb[region], s=220, facecolors="none", edgecolors="red", linewidths=1.8)
        ax.scatter(xa[fell], xb[fell], marker="x", c="k", s=18, linewidths=0.8)
        ax.plot([], [], "s", mfc="none", mec="red", label=f"best region ({int(region.sum())} points)")
        ax.plot([], [], "x", c="k", label="a trial fell / failed")
        ax.set_xlabel(a)
        ax.set_ylabel(b)
        ax.set_title(title, fontsize=9)
        ax.legend(fontsize=8, loc="upper right", framealpha=0.8)
        fig.colorbar(im, ax=ax, label=f"{metric} ({better} is better)")
    fig.suptitle(f"best region: the points with the highest survival rate whose {metric} is within "
                 f"{100 * tolerance:g} % of the best of them", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _edges(u: np.ndarray) -> np.ndarray:
    """Cell edges around sorted lattice values (midpoints; half a step beyond the ends)."""
    if len(u) == 1:
        return np.array([u[0] - 0.5, u[0] + 0.5])
    mid = (u[1:] + u[:-1]) / 2
    return np.concatenate([[u[0] - (mid[0] - u[0])], mid, [u[-1] + (u[-1] - mid[-1])]])


def varies_param(name: str) -> bool:
    """Columns that are trial parameters, not measured metrics."""
    return name in TRIAL_PARAMS


def _numeric(v) -> bool:
    try:
        a = v.astype(float)
    except (TypeError, ValueError):
        return False
    return a.size > 0 and not all(isinstance(x, bool) for x in v)
