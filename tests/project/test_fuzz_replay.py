"""The fuzz harnesses' re-measurement of slow ticks (``benchmarks/fuzz_common.replay_over``): a replayed episode is
the same ticks as in the run (same draws, same paths), and the verdict is the median of the replays."""

import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
import fuzz  # noqa: E402
import fuzz_common  # noqa: E402
import fuzz_id  # noqa: E402



def test_replay_over_takes_the_median_of_interleaved_replays():
    calls = []
    ratios = {(1, 100, 0): iter([[0.5, 2.6, 0.4], [0.5, 1.2, 0.4], [0.5, 1.1, 0.4]]),
              (1, 100, 3): iter([[0.3, 0.3], [2.5, 2.5], [2.4, 0.1]]),
              (2, 100, 5): iter([[0.2], [0.2], [0.2]])}

    def replay(seed, n, ep):
        calls.append((seed, n, ep))
        return next(ratios[(seed, n, ep)])

    over = [[1, 100, 0, 1, 3.0], [1, 100, 3, 0, 2.2], [2, 100, 5, 4, 2.1]]
    rep = fuzz_common.replay_over(over, replay)
    # three rounds, each replaying every episode once: A B C A B C A B C
    assert calls == [(1, 100, 0), (1, 100, 3), (2, 100, 5)] * 3
    # medians: 1.2 (fast again), 2.4 (slow again), a tick its replay did not reach (inf, slow)
    assert rep["over"] == 3 and rep["slow"] == 2 and rep["max_median"] == np.inf
    assert "median 1.20 x" in rep["records"][0] and "median 2.40 x" in rep["records"][1]


@pytest.mark.parametrize("n_over, replayed, ok", [(0, None, True), (2, None, False), (2, (2, 0), True),
                                                  (2, (2, 1), False), (3, (2, 0), False)])
def test_the_tick_cpu_line_passes_only_on_replays_of_every_slow_tick(n_over, replayed, ok):
    total = {} if replayed is None else {"replayed": {"over": replayed[0], "slow": replayed[1], "max_median": 1.0}}
    assert fuzz_common.over_line(total, 3.0, n_over, 10)[2] is ok


def test_a_replayed_episode_runs_the_same_ticks_as_the_run(robots, monkeypatch):
    robot = robots("humanoid15")
    limits = {"humanoid15": fuzz_common.joint_limits(robot)}
    monkeypatch.setattr(fuzz_common, "_ROBOTS", {"robots": {"humanoid15": robot}, "limits": limits})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        kwargs = dict(dts=(0.002, 0.01), past_limits=0.5, budget=0.0002, quiet=True)
        run = fuzz.run_chunk({"humanoid15": robot}, limits, 9, 3, 7, **kwargs)
        again = fuzz.run_chunk({"humanoid15": robot}, limits, 9, 3, 7, replay=2, **kwargs)
        run_id = fuzz_id.run_chunk(6, 7, episode=3, warm=False, quiet=True)
        again_id = fuzz_id.run_chunk(6, 7, episode=3, replay=1, warm=False, quiet=True)
    assert again["tick_paths"] == run["tick_paths"][6:9]
    assert again["tick_budget"] == run["tick_budget"][6:9]
    assert again_id["tick_paths"] == run_id["tick_paths"][3:6]
    # a 0.2 ms budget: the ticks over 2 x (their CPU time over their budget) are kept with what their replay needs
    ratio = np.array(run["tick_cpu"]) / np.array(run["tick_budget"])
    assert np.sum(ratio > 2.0) >= 3
    assert run["over_2x"] == [[7, 9, i // 3, i % 3, ratio[i]] for i in np.flatnonzero(ratio > 2.0)]
