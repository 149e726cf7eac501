"""Campaign statistics and plots: survival rates with Wilson score intervals, overall and per factor, the survival
map of push force against direction (and against gait phase), metric histograms, and a sweep's survival map over its
two parameters with the best region marked.

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

from wbc.campaign.store import finished_mask
from wbc.exceptions import InvalidInputError

__all__ = ["wilson_interval", "summarize_campaign", "factor_table", "make_plots", "format_report"]


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
    """The campaign's text report: overall survival with its Wilson 95 % interval, fall criteria, per factor."""
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
        factors = [f for f in ("force", "direction_deg", "phase", "mass_error", "friction", "armature", "delay",
                               "q_noise_deg", "v_noise", "payload") if f in table.column_names]
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


def make_plots(table, out_dir, *, sweep_params=None) -> list[Path]:
    """Write the campaign's PNG plots into ``out_dir`` (created): ``survival_map.png`` (force vs direction, and vs
    phase, when those columns vary), ``metrics.png`` (histograms of the numeric metrics, survivors vs the rest) and,
    for a sweep, ``sweep.png`` (survival rate per point over its two parameters, best points marked).

    Returns:
        The written paths.

    Raises:
        InvalidInputError: ``out_dir`` is a file or cannot be created.
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
        fig, ax = plt.subplots(figsize=(6.5, 5))
        sc = ax.scatter(xa, xb, c=rate, cmap="RdYlGn", vmin=0, vmax=1, s=60, edgecolors="k", linewidths=0.3)
        best = rate >= rate.max() - 1e-12
        ax.scatter(xa[best], xb[best], s=200, facecolors="none", edgecolors="b", linewidths=1.5,
                   label=f"best: {rate.max():.2f} over {int(nrep[best][0])} pushes ({best.sum()} points)")
        ax.set_xlabel(a)
        ax.set_ylabel(b)
        ax.legend(fontsize=8, loc="upper right")
        fig.colorbar(sc, ax=ax, label="survival rate (same pushes at every point)")
        fig.tight_layout()
        path = out_dir / "sweep.png"
        fig.savefig(path, dpi=110)
        plt.close(fig)
        written.append(path)
    return written


def varies_param(name: str) -> bool:
    """Columns that are trial parameters, not measured metrics."""
    return name in {"force", "direction_deg", "phase", "push_duration", "mass_error", "payload", "friction",
                    "armature", "delay", "q_noise_deg", "v_noise", "k_xi", "k_i", "k_z", "cop_margin", "cmp_offset",
                    "adjust_dead_band"}


def _numeric(v) -> bool:
    try:
        a = v.astype(float)
    except (TypeError, ValueError):
        return False
    return a.size > 0 and not all(isinstance(x, bool) for x in v)
