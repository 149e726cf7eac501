"""Mirrored push pairs on a Talos physics walk (record 40): is the push response left/right symmetric?

Each pair is one seeded push of ``benchmarks/walk_push_trials.py`` (time ``t`` uniform over the walking steps,
direction ``d`` uniform in [0, 360) deg, both from ``numpy.random.default_rng(seed)``), run twice as ``wbc sim walk``
(``benchmarks/mirror_walk.py``): A swings the left foot first and is pushed towards ``d`` at ``t``; B is its sagittal
mirror image: the right foot swings first and the push goes towards ``-d`` at the same ``t`` (the same time in the
other foot's single support). A left/right symmetric robot, plan, controller and plant give mirror-image runs, so
the two outcomes agree and ``|M dcm_A - dcm_B|`` (M = diag(1, -1)) stays at zero; the sensor noise (seeded by
``--noise-seed``, default the pair's seed) is the same draw on the same physical sensor, so it is not mirrored.

Prints one line per pair (outcome, max DCM error, min measured CoP margin, worst joint speed ratio of A and B, and
the mirror deviation of the DCM before and after the push) and the totals: pairs agreeing, A-only falls, B-only falls.

Usage: python benchmarks/push_mirror_pairs.py [--robot talos] [--seed0 26112800] [--trials 20] [--seeds S ...] [--force 300]
       [--campaign SEED [--campaign-trials 60]] [--dir-range LO HI]
       [--state estimated|ground-truth] [--plant realistic|ideal] [--noise-seed N] [--jobs 1] [--dir D]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
T_INIT = 0.8  # WalkScenario's initial double support


def draw(seed: int, steps: int, step_duration: float, duration: float) -> tuple[float, float]:
    """(push time s, push direction deg) of ``walk_push_trials.py``'s trial ``seed``."""
    rng = np.random.default_rng(seed)
    t = float(T_INIT + rng.uniform(0.0, (steps - 1) * step_duration - duration))
    return t, float(rng.uniform(0.0, 360.0))


def run(side: str, t: float, d: float, args, noise_seed: int, out: str) -> dict:
    """One ``wbc sim walk`` with the first swing foot ``side``: its JSON summary, the npz log at ``out``.npz."""
    cmd = [sys.executable, os.path.join(HERE, "mirror_walk.py"), side, "--robot", args.robot, "--steps", str(args.steps),
           "--step-length", repr(args.step_length), "--step-duration", repr(args.step_duration), "--push",
           repr(args.force), "--push-time", repr(t), "--push-dir", repr(d), "--push-duration", repr(args.duration),
           "--plant", args.plant, "--state", args.state, "--seed", str(noise_seed), "--quiet",
           "--json", out + ".json", "--log", out + ".npz"]
    done = subprocess.run(cmd, capture_output=True, text=True)
    if done.returncode not in (0, 1):
        raise RuntimeError(f"{' '.join(cmd)} exited {done.returncode}: {done.stderr[-2000:]}")
    with open(out + ".json") as f:
        return json.load(f)


def mirror_deviation(a: str, b: str, t_push: float) -> tuple[float, float]:
    """max |M dcm_A - dcm_B| (m) before the push and over the 1 s after its start (NaN rows skipped)."""
    za, zb = np.load(a + ".npz"), np.load(b + ".npz")
    n = min(len(za["t"]), len(zb["t"]))
    t = za["t"][:n]
    dev = np.linalg.norm(za["dcm"][:n] * [1.0, -1.0] - zb["dcm"][:n], axis=1)
    pre, post = (t < t_push), (t >= t_push) & (t < t_push + 1.0)
    f = lambda m: float(np.nanmax(dev[m])) if np.isfinite(dev[m]).any() else float("nan")
    return f(pre), f(post)


def campaign_draw(seed: int, index: int, trials: int) -> tuple[float, float, float]:
    """(push time s, direction deg, force N) of trial ``index`` of the default push campaign ``seed`` (``wbc campaign
    run --kind push --seed SEED --trials TRIALS``: wbc.campaign.trials' push time, the trial index as noise seed)."""
    from wbc.campaign.spec import default_spec, trial_params

    spec = default_spec("push", seed=seed, trials=trials)
    p, sc = trial_params(spec, index), spec.scenario
    t_walk = max(0.0, (sc["steps"] - 1) * sc["step_duration"] - p["push_duration"])
    return T_INIT + p["phase"] * t_walk, float(p["direction_deg"]), float(p["force"])


def pair(job):
    seed, args = job
    if args.campaign is None:
        t, d = draw(seed, args.steps, args.step_duration, args.duration)
    else:  # the campaign's trial `seed` (its index), at its own force
        t, d, force = campaign_draw(args.campaign, seed, args.campaign_trials)
        args = argparse.Namespace(**{**vars(args), "force": force})
    noise = seed if args.noise_seed is None else args.noise_seed
    tag = os.path.splitext(os.path.basename(args.robot))[0]
    base = os.path.join(args.dir, f"{tag}-{args.state}-{args.plant}-{seed}")
    sa = run("left", t, d, args, noise, base + "-A")
    sb = run("right", t, (-d) % 360.0, args, noise, base + "-B")
    pre, post = mirror_deviation(base + "-A", base + "-B", t)
    ok = [bool(not s["fell"] and s["completed"] and s["joint_speed_exceedances"] == 0) for s in (sa, sb)]

    def one(s, good):
        return (f"{'ok  ' if good else 'FELL'} dcm {s['max_dcm_error_m'] * 1e3:5.1f} mm cop {s['min_measured_cop_margin_m'] * 1e3:+6.1f} "
                f"mm speed {s.get('max_joint_speed_ratio', float('nan')):.2f}x adj {s['step_adjustments']}"
                f"{' (' + s['fall_reason'] + ')' if s['fell'] else ''}")

    line = (f"{'trial' if args.campaign is not None else 'seed'} {seed}: {args.force:.0f} N, t {t:.3f} s, A left-first {d:6.1f} deg: {one(sa, ok[0])} | B right-first {(-d) % 360:6.1f} deg: "
            f"{one(sb, ok[1])} | mirror dev dcm pre {pre * 1e3:.2f} mm, post {post * 1e3:.1f} mm")
    return seed, ok, line, dict(seed=seed, t=t, d=d, A=sa, B=sb, dev_pre=pre, dev_post=post)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robot", default="talos", help="catalog name or robot file (default talos)")
    ap.add_argument("--seed0", type=int, default=26112800)
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--seeds", type=int, nargs="+")
    ap.add_argument("--force", type=float, default=300.0)
    ap.add_argument("--duration", type=float, default=0.1)
    ap.add_argument("--steps", type=int, default=8)
    ap.add_argument("--step-length", type=float, default=0.25)
    ap.add_argument("--step-duration", type=float, default=0.6)
    ap.add_argument("--state", choices=("ground-truth", "estimated"), default="estimated")
    ap.add_argument("--plant", choices=("ideal", "realistic"), default="realistic")
    ap.add_argument("--noise-seed", type=int, default=None, help="sensor noise seed of every run (default: the pair's seed)")
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--dir", default=None, help="keep the JSON summaries and npz logs here (default: a temporary dir)")
    ap.add_argument("--campaign", type=int, default=None, metavar="SEED",
                    help="pairs of the default push campaign SEED's trials (indices from --seeds, or all "
                         "--campaign-trials), each at its own force, time and direction; noise seed = trial index")
    ap.add_argument("--campaign-trials", type=int, default=60, help="the campaign's trial count (default 60)")
    ap.add_argument("--dir-range", type=float, nargs=2, default=None, metavar=("LO", "HI"),
                    help="only the pairs whose A push direction is in [LO, HI) deg (mod 360)")
    ap.add_argument("--out", default=None, help="write every pair's summaries as JSON here")
    args = ap.parse_args()
    if args.campaign is not None:
        seeds = args.seeds or list(range(args.campaign_trials))
    else:
        seeds = args.seeds or [args.seed0 + i for i in range(args.trials)]
    if args.dir_range is not None:
        lo, hi = args.dir_range

        def a_dir(s):
            d = campaign_draw(args.campaign, s, args.campaign_trials)[1] if args.campaign is not None else \
                draw(s, args.steps, args.step_duration, args.duration)[1]
            return (d - lo) % 360.0 < (hi - lo) % 360.0

        seeds = [s for s in seeds if a_dir(s)]
    with tempfile.TemporaryDirectory() as tmp:
        args.dir = args.dir or tmp
        os.makedirs(args.dir, exist_ok=True)
        jobs = [(s, args) for s in seeds]
        if args.jobs > 1:
            import multiprocessing

            with multiprocessing.get_context("spawn").Pool(args.jobs) as pool:
                results = list(pool.imap(pair, jobs))
        else:
            results = []
            for j in jobs:
                results.append(pair(j))
                print(results[-1][2], flush=True)
        if args.jobs > 1:
            for r in results:
                print(r[2], flush=True)
    a = sum(r[1][0] for r in results)
    b = sum(r[1][1] for r in results)
    agree = sum(r[1][0] == r[1][1] for r in results)
    force = f"campaign {args.campaign} forces" if args.campaign is not None else f"{args.force:.0f} N"
    print(f"{args.state} state, {args.plant} plant, {force} x {args.duration} s: A (left first, d) survived "
          f"{a}/{len(results)}, B (right first, -d) survived {b}/{len(results)}; outcomes agree in {agree}/{len(results)}; "
          f"A-only falls {[r[0] for r in results if not r[1][0] and r[1][1]]}, B-only falls "
          f"{[r[0] for r in results if r[1][0] and not r[1][1]]}; median mirror dev of the DCM before the push "
          f"{np.nanmedian([r[3]['dev_pre'] for r in results]) * 1e3:.2f} mm")
    if args.out:
        with open(args.out, "w") as f:
            json.dump([r[3] for r in results], f)


if __name__ == "__main__":
    main()
