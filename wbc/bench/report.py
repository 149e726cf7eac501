"""Benchmark outputs: ``results.json`` (machine info + every number), ``results.md`` (tables), ``latency.png``
(latency distributions) and ``latencies.npz`` (raw per-tick wall times, ns) in one folder.

Every number written here comes from :func:`wbc.bench.suite.run_suite`; nothing is typed in by hand.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

__all__ = ["benchmark_goals", "write_report", "markdown", "plot_latencies"]


def _jsonable(x):
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items() if not str(k).startswith("_")}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, (np.floating, float)):
        return float(x) if math.isfinite(float(x)) else str(float(x))
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (np.bool_,)):
        return bool(x)
    return x


def benchmark_goals(results: dict) -> list[dict[str, object]]:
    """The issue's acceptance criteria evaluated on ``results``: [{criterion, value, goal, met, timing}].

    ``timing`` is True for a wall-clock criterion (meaningful only on a quiet machine with full repeats)."""
    rows: list[dict[str, object]] = []
    kin = results.get("kinematic")
    if kin:
        ratios = kin.get("ratios_to_placo", {})
        if "wbc" in ratios:
            r = ratios["wbc"]["median"]
            rows.append({"criterion": "wbc kinematic tick median / placo (median of per-repeat ratios)",
                         "value": r, "goal": "≤ 1.0", "met": r <= 1.0, "timing": True})
        if "wbc" in ratios and "pink" in ratios:
            per = [p / w for p, w in zip(ratios["pink"]["per_repeat"], ratios["wbc"]["per_repeat"])]
            r = float(np.median(per))
            rows.append({"criterion": "Pink tick median / wbc (median of per-repeat ratios)", "value": r,
                         "goal": "≥ 4", "met": r >= 4.0, "timing": True})
        sw = kin.get("same_work", {})
        rows.append({"criterion": "same-work check, kinematic (all libraries)",
                     "value": ", ".join(f"{k}: {v['verdict']}" for k, v in sw.items()), "goal": "all ok",
                     "met": bool(sw) and all(v["passed"] for v in sw.values()), "timing": False})
    ins = results.get("instructions")
    if ins:
        if "error" in ins:
            rows.append({"criterion": "instructions per kinematic tick, wbc / placo (callgrind, N vs 2N)",
                         "value": ins["error"], "goal": "≤ 0.8", "met": None, "timing": False})
        else:
            rows.append({"criterion": f"instructions per kinematic tick, wbc / placo (callgrind, {ins['n']} vs "
                         f"{2 * ins['n']} ticks differenced)", "value": ins["ratio_wbc_placo"], "goal": "≤ 0.8",
                         "met": ins["ratio_wbc_placo"] <= 0.8, "timing": False})
    host = results.get("instructions_host")
    if host and "error" not in host:
        rows.append({"criterion": f"the same, wbc's kernels compiled for {host['cpu']}", "value":
                     host["ratio_wbc_placo"], "goal": "≤ 0.8", "met": host["ratio_wbc_placo"] <= 0.8, "timing": False})
    walk = results.get("walk")
    if walk:
        libs = walk["libraries"]
        ratio = walk.get("ratios_to_placo-hard", {}).get("wbc")
        if ratio is not None:
            rows.append({"criterion": "wbc walk tick median / placo hard-feet walk (median of per-repeat ratios)",
                         "value": ratio, "goal": "≤ 1.5", "met": ratio <= 1.5, "timing": True})
        rows.append({"criterion": "wbc walk tick p99 (µs, median over repeats; quiet machine)",
                     "value": libs["wbc"]["p99_us"], "goal": "≤ 250", "met": libs["wbc"]["p99_us"] <= 250.0,
                     "timing": True})
        rows.append({"criterion": "wbc walk: no failed tick, finite motion", "value": libs["wbc"]["failures"],
                     "goal": "0 failures", "met": libs["wbc"]["failures"] == 0 and libs["wbc"]["finite"],
                     "timing": False})
    dyn = results.get("dynamics")
    if dyn and "wbc" in dyn.get("ratios_to_placo", {}):
        r = dyn["ratios_to_placo"]["wbc"]["median"]
        rows.append({"criterion": "wbc inverse-dynamics tick median / placo DynamicsSolver", "value": r,
                     "goal": "≤ 1.0", "met": r <= 1.0, "timing": True})
    ft = results.get("frame_tasks")
    if ft:
        v = ft["per_task_us"]["wbc"]
        rows.append({"criterion": "one extra 6-D frame task, wbc µs per task (median of per-repeat differences)",
                     "value": v, "goal": "≤ 6", "met": v <= 6.0, "timing": True})
    gait = results.get("gait")
    if gait:
        w = gait["wbc"]
        rows.append({"criterion": "wbc 6-step plan median (µs)", "value": w["plan_us"]["median"], "goal": "≤ 1000",
                     "met": w["plan_us"]["median"] <= 1000.0, "timing": True})
        rows.append({"criterion": "wbc plan min ZMP margin every 2 ms (mm)", "value": 1e3 * w["plan"]["min_margin_m"],
                     "goal": "≥ 0", "met": w["plan"]["min_margin_m"] >= 0.0, "timing": False})
    return rows


def _f(x, digits: int = 1) -> str:
    if x is None:
        return "—"
    if isinstance(x, str):
        return x
    if not math.isfinite(float(x)):
        return str(x)
    return f"{float(x):.{digits}f}"


def _g(x) -> str:
    return "—" if x is None else f"{float(x):.3g}"


def _lib_table(section: dict, reference: str = "placo") -> list[str]:
    ratios = section.get(f"ratios_to_{reference}", {})
    lines = [f"| library | QP solver | median µs | p90 µs | p99 µs | max µs | CPU median µs | CPU p99 µs | "
             f"ratio to {reference} (wall, median of per-repeat) | ratio (CPU) | failed ticks |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for lib, v in section["libraries"].items():
        w, c = v["wall_us"], v["cpu_us"]
        r = ratios.get(lib, {})
        lines.append(f"| {lib} | {v['solver']} | {_f(w['median'])} | {_f(w['p90'])} | {_f(w['p99'])} | "
                     f"{_f(w['max'])} | {_f(c['median'])} | {_f(c['p99'])} | {_f(r.get('median'), 2)} | "
                     f"{_f(r.get('cpu_median'), 2)} | {v['failures']} |")
    return lines


def _same_work_table(section: dict) -> list[str]:
    lines = ["| library | final CoM error mm | max CoM error mm | final CoM vs placo mm | feet drift mm | "
             "feet rotation mrad | max position-limit violation rad | max velocity-limit violation rad/s | verdict |",
             "|---|---|---|---|---|---|---|---|---|"]
    libs = section["libraries"]
    ref = libs.get("placo", {}).get("metrics", {}).get("final_com")
    for lib, v in libs.items():
        m = v["metrics"]
        gap = None if ref is None else 1e3 * float(np.linalg.norm(np.subtract(m["final_com"], ref)))
        sw = section["same_work"][lib]
        err = v.get("first_error", "")
        verdict = sw["verdict"] + ("" if sw["passed"] else f" ({'; '.join(sw['failed'])}"
                                   + (f"; first error: {err}" if err else "") + ")")
        lines.append(f"| {lib} | {_f(1e3 * m['final_com_error'], 3)} | {_f(1e3 * m['max_com_error'], 3)} | "
                     f"{_g(gap)} | {_g(1e3 * m['feet_drift'])} | {_g(1e3 * m['feet_rotation'])} | "
                     f"{_g(m['position_limit_violation'])} | {_g(m['velocity_limit_violation'])} | {verdict} |")
    return lines


def markdown(results: dict) -> str:
    """The markdown report of ``results``."""
    m = results["machine"]
    v = m["versions"]
    out = [f"# wbc benchmarks — {m['date_utc']}", "",
           f"Machine: {m['cpu_model']}, {m['logical_cores']} logical cores ({m['usable_cores']} usable), "
           f"load average {m['load_average_1_5_15']} before / {m.get('load_average_after')} after, {m['os']}. "
           f"BLAS threads: {m.get('blas_threads', 'default')}.",
           f"Python {m['python']}, " + ", ".join(f"{k} {val}" for k, val in v.items() if val) + ".",
           f"Whole run: {_f(results.get('runtime_s'))} s.", ""]
    acc = benchmark_goals(results)
    if acc:
        out += ["## Acceptance", "", "| criterion | measured | goal | met |", "|---|---|---|---|"]
        out += [f"| {a['criterion']} | {_f(a['value'], 2) if not isinstance(a['value'], str) else a['value']} | "
                f"{a['goal']} | {'yes' if a['met'] else ('not measured' if a['met'] is None else '**no**')} |"
                for a in acc]
        out.append("")
    kin = results.get("kinematic")
    if kin:
        s = kin["spec"]
        out += [f"## 1. Kinematic tick, {s['robot']} (nv {kin['nv']}), {s['ticks']} timed ticks × "
                f"{results['config']['repeats']} interleaved repeats, dt {s['dt'] * 1e3:g} ms", "",
                "Scope of one tick: set the CoM target + solve + integrate + update kinematics. Both soles are hard "
                "equality constraints in all three libraries; every task is dead-beat with the same weights "
                f"(CoM {s['com_weight']:g}, torso {s['torso_weight']:g}, posture {s['posture_weight']:g}; "
                f"step regularisation {s['damping']:g}). median = median of the per-repeat medians; p90/p99/max "
                "pooled over repeats.", ""]
        out += _lib_table(kin)
        out += ["", "Same-work check (worst over repeats; tolerances: CoM and feet "
                f"{kin['tolerance']['com'] * 1e3:g} mm, feet rotation {kin['tolerance']['feet_rotation'] * 1e3:g} mrad,"
                f" limits {kin['tolerance']['limit']:g}):", ""]
        out += _same_work_table(kin)
        sel = kin.get("pink_selection", {})
        if sel.get("solvers"):
            out += ["", f"Pink solver pre-pass ({sel['ticks']} ticks × {sel.get('rounds', 1)} interleaved rounds, "
                    "median of the round medians; the fastest valid one is used: "
                    f"**{sel['selected']}**): " + ", ".join(
                        f"{k} {_f(r.get('median_us'))} µs" + (f" ({r['failures']} failed ticks)" if r.get('failures') else "")
                        + (f" [{r['same_work']}]" if r.get("same_work") not in (None, "ok") else "")
                        if "error" not in r else f"{k} error" for k, r in sel["solvers"].items()) + "."]
        notes = [f"{lib}: {v['note']}" for lib, v in kin["libraries"].items() if v.get("note")]
        if notes:
            out += ["", "Configuration notes: " + "; ".join(notes) + "."]
        out.append("")
    bd = results.get("breakdown")
    if bd:
        tick = bd["tick_us"]["median"]
        out += [f"## 2. wbc tick breakdown ({results['config']['repeats']} repeats with per-phase timers, interleaved "
                "with placo)", "",
                f"Tick median {_f(tick)} µs. Phases (median of the per-repeat medians of each phase; they need not add "
                "up exactly):", "",
                "| phase | median µs | p99 µs | share of tick median |", "|---|---|---|---|"]
        for k, p in bd["phases_us"].items():
            out.append(f"| {k} | {_f(p['median'])} | {_f(p['p99'])} | {_f(100 * p['median'] / tick, 0)} % |")
        placo = (bd.get("placo_tick_us") or {}).get("median")
        if placo:
            ph = bd["phases_us"]
            out += ["", f"For scale: placo's whole tick, measured in the same interleaved runs, has a median of "
                    f"{_f(placo)} µs; wbc's QP solve "
                    f"alone {_f(ph['solve']['median'])} µs ({_f(ph['solve']['median'] / placo, 1)}× placo's tick), its "
                    f"Python assembly {_f(ph['assembly']['median'])} µs ({_f(ph['assembly']['median'] / placo, 1)}×), "
                    f"its Pinocchio update {_f(ph['kinematics']['median'])} µs."]
        out += ["", "Top functions by own time (cProfile; inflates Python costs, read it as a ranking):", "",
                "| function | calls/tick | own µs/tick | cumulative µs/tick |", "|---|---|---|---|"]
        for r in bd["profile_top"]:
            out.append(f"| `{r['function']}` | {_f(r['calls_per_tick'], 1)} | {_f(r['own_us_per_tick'])} | "
                       f"{_f(r['cumulative_us_per_tick'])} |")
        out.append("")
    sol = results.get("solvers")
    if sol:
        out += [f"## 3. wbc with each QP backend (same scenario, {sol.get('repeats', 1)} interleaved repeats, per-phase "
                "timers on; medians of the per-repeat medians)", "",
                "| solver | tick median µs | tick p99 µs | tick max µs | assembly median µs | solve median µs | "
                "failed ticks | max position-limit violation rad | max velocity-limit violation rad/s | "
                "limits held exactly (≤ 0) | same work |",
                "|---|---|---|---|---|---|---|---|---|---|---|"]
        for name, r in sol["solvers"].items():
            if "error" in r:
                out.append(f"| {name} | error: {r['error']} | | | | | | | | | |")
                continue
            w, mm, ph = r["wall_us"], r["metrics"], r.get("phases_us", {})
            verdict = r["same_work"]["verdict"] + ("" if r["same_work"]["passed"]
                                                   else f" ({'; '.join(r['same_work']['failed'])})")
            out.append(f"| {name} | {_f(w['median'])} | {_f(w['p99'])} | {_f(w['max'])} | "
                       f"{_f(ph.get('assembly', {}).get('median'))} | {_f(ph.get('solve', {}).get('median'))} | "
                       f"{r['failures']} | {_g(mm['position_limit_violation'])} | "
                       f"{_g(mm['velocity_limit_violation'])} | {'yes' if r['limits_held_exactly'] else 'no'} | "
                       f"{verdict} |")
        out.append("")
    sc = results.get("scaling")
    if sc:
        out += [f"## 4. Scaling over robots (same scenario, {results['config']['repeats']} interleaved repeats each)", "",
                "| robot | nv | wbc median µs | placo median µs | Pink median µs | wbc / placo | Pink / wbc | same work |",
                "|---|---|---|---|---|---|---|---|"]
        void_notes = []
        for name, r in sc["robots"].items():
            libs, sw = r["libraries"], r["same_work"]
            med = {k: v["wall_us"]["median"] for k, v in libs.items()}
            ok = {k: v["passed"] for k, v in sw.items()}
            ratio = r.get("ratios_to_placo", {}).get("wbc", {}).get("median")
            ratio_s = _f(ratio, 2) if ok.get("wbc") and ok.get("placo") else "void"
            pw = med["pink"] / med["wbc"] if "pink" in med and "wbc" in med else None
            pw_s = _f(pw, 2) if ok.get("wbc") and ok.get("pink") else ("—" if pw is None else "void")
            verdicts = ", ".join(f"{k} {v['verdict']}" for k, v in sw.items())
            out.append(f"| {name} | {r['nv']} | {_f(med.get('wbc'))} | {_f(med.get('placo'))} | {_f(med.get('pink'))} |"
                       f" {ratio_s} | {pw_s} | {verdicts} |")
            for lib, v in sw.items():
                if not v["passed"]:
                    err = libs[lib].get("first_error", "")
                    void_notes.append(f"{name}/{lib}: {'; '.join(v['failed'])}" + (f" — first error: {err}" if err else ""))
        if void_notes:
            out += ["", "VOID entries: " + " | ".join(void_notes)]
        out.append("")
    dyn = results.get("dynamics")
    if dyn:
        s = dyn["spec"]
        out += [f"## 5. Inverse dynamics tick, {s['robot']}, {s['ticks']} ticks × {results['config']['repeats']} "
                "interleaved repeats", ""]
        if not dyn["wbc_available"]:
            out += [f"wbc: **not available** — {dyn['wbc_unavailable_reason']}", ""]
        out += ["Standing on both soles (contacts with friction μ = " f"{s['mu']:g}), torque, joint and velocity "
                "limits, CoM sway tracked by PD + feed-forward, torso orientation, posture. Each library integrates "
                "its own accelerations (no simulator).", ""]
        out += _lib_table(dyn)
        bd = dyn.get("wbc_breakdown_us")
        if bd:
            out += ["", f"wbc ID tick breakdown (the same runs; wbc's per-phase timers were on, < 1 µs per tick), "
                    f"tick median {_f(bd['tick']['median'])} µs: "
                    f"Pinocchio (M, h, Jacobians, drifts) {_f(bd['kinematics']['median'])} µs, "
                    f"assembly {_f(bd['assembly']['median'])} µs, QP solve {_f(bd['solve']['median'])} µs (medians)."]
        out += ["", "Same-work check:", ""] + _same_work_table(dyn)
        notes = [f"{lib}: {v['note']}" for lib, v in dyn["libraries"].items() if v.get("note")]
        out += ["", "Model differences: " + "; ".join(notes) + ".", ""]
    gait = results.get("gait")
    if gait:
        g = gait["spec"]
        out += [f"## 6. Gait planning, {gait['robot']}: {g['n_steps']} steps of {g['step_length']:g} m, single support "
                f"{g['t_ss']:g} s, double {g['t_ds']:g} s, start/end {g['t_startend']:g} s", "",
                f"Timings: {g['repeats']} wbc and {g['placo_repeats']} placo plans (and as many replans), interleaved over "
                f"{g.get('rounds', 1)} rounds; median = median of the round medians. "
                "ZMP recomputed from each plan's CoM every 2 ms (p = c − c̈ z/g); margin = signed distance to the "
                "support polygon of each planner's own phases (positive inside).", "",
                "| planner | plan median µs | plan p99 µs | replan median µs | replan p99 µs | min ZMP margin plan mm | "
                "samples < 0 | samples < 20 mm | min margin after replan mm |", "|---|---|---|---|---|---|---|---|---|"]
        for name in ("wbc", "placo"):
            r = gait.get(name)
            if r is None:
                continue
            if "error" in r:
                out.append(f"| {name} | error: {r['error']} | | | | | | | |")
                continue
            out.append(f"| {name} | {_f(r['plan_us']['median'])} | {_f(r['plan_us']['p99'])} | "
                       f"{_f(r['replan_us']['median'])} | {_f(r['replan_us']['p99'])} | "
                       f"{_f(1e3 * r['plan']['min_margin_m'], 1)} | {r['plan']['samples_below_0']} / "
                       f"{r['plan']['samples']} | {r['plan']['samples_below_20mm']} | "
                       f"{_f(1e3 * r['replan']['min_margin_m'], 1)} |")
        p = gait.get("placo", {})
        if "knot_s" in p:
            out += ["", f"placo: knots every {p['knot_s'] * 1e3:g} ms, zmp_margin parameter "
                    f"{p['zmp_margin_param_m'] * 1e3:g} mm; replan from t = {p['replan_t']:g} s "
                    f"(success: {p['replan_success']}). wbc replans from the same time."]
        out.append("")
    if results.get("walk"):
        out += _walk_section(results["walk"])
    if results.get("frame_tasks"):
        out += _frame_task_section(results["frame_tasks"])
    ins = results.get("instructions")
    if ins:
        out += ["## 9. Instructions per kinematic tick (valgrind callgrind; independent of machine load)", ""]
        if "error" in ins:
            out += [ins["error"], ""]
        else:
            out += [f"Each library ran the kinematic scenario under callgrind with {ins['n']} and {2 * ins['n']} timed "
                    "ticks; the difference divided by N cancels start-up, imports and JIT loading. wbc's numba "
                    f"kernels were compiled for the {ins.get('cpu', 'generic')} x86-64 CPU (placo's wheel is built for "
                    "the generic baseline): benchmarks/method.md.", "",
                    "| library | instructions per tick | / placo |", "|---|---|---|"]
            for lib, n in ins["instructions"].items():
                out.append(f"| {lib} | {n / 1e3:.0f} k | {n / ins['instructions']['placo']:.2f} |")
            host = results.get("instructions_host")
            if host and "error" not in host:
                wbc_host = host["instructions"]["wbc"]
                out.append(f"| wbc, kernels for {host['cpu']} | {wbc_host / 1e3:.0f} k | "
                           f"{wbc_host / host['instructions']['placo']:.2f} |")
            out.append("")
    if "jit_first_call_s" in results:
        out += [f"numba kernels, first call in this process (compile, or load from the on-disk cache): "
                f"{results['jit_first_call_s']:.2f} s.", ""]
    return "\n".join(out)


def plot_latencies(results: dict, path: Path) -> Path | None:
    """Latency distributions (log x): top row ECDF, bottom row exceedance 1 − ECDF (log y, the tail), one column
    per comparison (kinematic, inverse dynamics). Returns the PNG path, or None when there is nothing to plot."""
    raw = results.get("_raw", {})
    panels = [(k, t) for k, t in (("kinematic", "Kinematic tick"), ("dynamics", "Inverse-dynamics tick")) if raw.get(k)]
    if not panels:
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    import matplotlib.ticker  # noqa: F401  (NullFormatter for the minor ticks)

    fig, axes = plt.subplots(2, len(panels), figsize=(6.5 * len(panels), 7.5), squeeze=False, sharex="col")
    all_us = np.concatenate([np.asarray(v, dtype=float) / 1e3 for key, _ in panels for v in raw[key].values()])
    lo, hi = 0.8 * float(all_us.min()), 1.25 * max(float(all_us.max()), 2000.0)
    colors = {"wbc": "tab:blue", "placo": "tab:orange", "pink": "tab:green"}
    for col, (key, title) in enumerate(panels):
        section = results.get(key, {})
        top, bottom = axes[0][col], axes[1][col]
        for lib, ns in raw[key].items():
            us = np.sort(np.asarray(ns, dtype=float) / 1e3)
            y = np.arange(1, us.size + 1) / us.size
            solver = section.get("libraries", {}).get(lib, {}).get("solver", "")
            med = section.get("libraries", {}).get(lib, {}).get("wall_us", {}).get("median", float(np.median(us)))
            label = f"{lib} ({solver}), median {med:.0f} µs"
            top.step(us, y, where="post", color=colors.get(lib), label=label)
            bottom.step(us, np.maximum(1.0 - y + 1.0 / us.size, 1.0 / us.size), where="post", color=colors.get(lib),
                        label=label)
        for ax in (top, bottom):
            ax.axvline(2000, color="grey", ls=":", lw=1)
            ax.set_xscale("log")
            ax.set_xlim(lo, hi)
            ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())
            ax.grid(True, which="both", alpha=0.3)
        top.text(1900, 0.5, "2 ms = 500 Hz period", color="grey", fontsize=8, ha="right", rotation=90)
        bottom.set_yscale("log")
        top.set_ylabel("fraction of ticks ≤ x")
        bottom.set_ylabel("fraction of ticks ≥ x (tail)")
        bottom.set_xlabel("tick wall time (µs, log scale)")
        top.set_title(f"{title}, {results['config']['robot']} ({results['config']['repeats']} repeats pooled)")
        top.legend(loc="lower right", fontsize=8)
    m = results["machine"]
    fig.suptitle(f"{m['cpu_model']}, {m['logical_cores']} cores, load {m['load_average_1_5_15'][0]:.2f} — "
                 f"{m['date_utc']}", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def write_report(results: dict, out_dir: Path) -> dict[str, Path]:
    """Write results.json, results.md, latency.png, latencies.npz into ``out_dir`` (created)."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    paths = {"json": out_dir / "results.json", "markdown": out_dir / "results.md"}
    data = _jsonable(results)
    data["acceptance"] = _jsonable(benchmark_goals(results))
    paths["json"].write_text(json.dumps(data, indent=2, ensure_ascii=False) + "\n")
    paths["markdown"].write_text(markdown(results) + "\n")
    png = plot_latencies(results, out_dir / "latency.png")
    if png is not None:
        paths["plot"] = png
    raw = results.get("_raw", {})
    arrays = {f"{sec}__{lib}": np.asarray(v) for sec, libs in raw.items() for lib, v in libs.items()}
    if arrays:
        paths["raw"] = out_dir / "latencies.npz"
        np.savez_compressed(paths["raw"], **arrays)
    return paths


def _walk_section(walk: dict) -> list[str]:
    """Markdown lines of the walk-tick section (wbc vs placo hard-feet and soft-feet walks)."""
    sp = walk["spec"]
    out = [f"## 7. Walk tick (the main job): default plan, {sp['n_steps']} steps, {walk['ticks']} ticks × "
           f"{sp['repeats']} interleaved repeats", "",
           "One tick = set the plan's references + solve + integrate + update kinematics. wbc: stance soles hard "
           "contacts, swing sole a soft frame task (support switches); placo-hard: both soles HARD frame tasks on "
           "the plan's sole poses; placo-soft: placo's own `WalkTasks` (soft feet). Errors are against the plan.",
           "", "| library | median µs | p99 µs (median over repeats) | max µs | / placo-hard | failures | "
           "max CoM error mm | max sole error mm |", "|---|---|---|---|---|---|---|---|"]
    for lib, v in walk["libraries"].items():
        out.append(f"| {lib} | {_f(v['wall_us']['median_of_repeat_medians'])} | {_f(v['p99_us'])} | "
                   f"{_f(v['wall_us']['max'])} | {_f(walk.get('ratios_to_placo-hard', {}).get(lib), 2)} | "
                   f"{v['failures']} | {_f(1e3 * v['max_com_error'], 2)} | {_f(1e3 * v['max_sole_error'], 2)} |")
    out.append("")
    return out


def _frame_task_section(ft: dict) -> list[str]:
    """Markdown lines of the extra-frame-task section."""
    n = len(ft["frames"])
    out = [f"## 8. Cost of an extra 6-D frame task: the kinematic tick with {n} more soft frame tasks, "
           f"{ft['ticks']} ticks × {ft['repeats']} interleaved repeats", "",
           f"Frames: {', '.join(ft['frames'])} (weight 1, target = initial placement). Per-task cost = (median tick "
           f"with them − median tick without) / {n}, per repeat; median over repeats.", "",
           f"| library | tick µs | tick + {n} tasks µs | µs per extra task |", "|---|---|---|---|"]
    for lib in ("wbc", "placo"):
        out.append(f"| {lib} | {_f(float(np.median(ft['tick_us'][lib])))} | "
                   f"{_f(float(np.median(ft['tick_us'][f'{lib}+{n}'])))} | {_f(ft['per_task_us'][lib])} |")
    out.append("")
    return out
