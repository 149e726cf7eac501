"""Walk timing: double / single support phases on the control-sample grid, and the ZMP reference knots.

Sequence of phases for ``n`` steps::

    DS_init (t_init) | SS_1 (t_ss) DS_1 (t_ds) | SS_2 ... | SS_n (t_ss) | DS_final (t_final)

(the single and double supports may differ in length, one ``t_ss`` and ``t_ds`` per step: step timing on terrain).

Every duration is rounded to a whole number of samples ``dt`` (at least one), so that phase boundaries, lift-off
and touch-down fall exactly on samples. A phase covers samples ``first .. first + count - 1``; its end sample
is the first sample of the next phase. The walk has ``sum(count) + 1`` samples; the last one closes DS_final.

ZMP reference (piecewise linear in time, one linear segment per row of :class:`ZmpSegments`):

* DS_init: from a start point chosen by the CoM planner (so that the plan starts exactly at the given CoM
  state) to the first stance sole centre;
* SS_i: constant at the stance sole centre;
* DS_i: linear from the stance sole centre to the next stance sole centre (the foot that just landed);
* DS_final: linear from the last stance sole centre to the final feet mid-point over ``min(t_ds, t_final/2)``,
  then constant there.

Sole centres are the sole-frame origins, so the reference lies in the sole rectangle in single support and on
the segment between the two sole centres (inside their convex hull) in double support.
"""

from __future__ import annotations

import math

from dataclasses import dataclass
from enum import IntEnum
from typing import NamedTuple

import numpy as np

from wbc.gait.footsteps import Footstep

__all__ = ["Support", "DOUBLE_SUPPORT", "LEFT_SUPPORT", "RIGHT_SUPPORT", "Phase", "ZmpSegments", "build_phases",
           "zmp_segments"]


class Support(IntEnum):
    """Support code of a tick, the one used by the gait plans, the scenarios and their logs (``support`` arrays,
    int8): which soles are in contact with the ground."""

    DOUBLE = 0  #: both soles in stance
    LEFT = 1  #: left foot in stance, right foot swinging
    RIGHT = 2  #: right foot in stance, left foot swinging


# The same members under the gait layer's names.
DOUBLE_SUPPORT, LEFT_SUPPORT, RIGHT_SUPPORT = Support.DOUBLE, Support.LEFT, Support.RIGHT


class Phase(NamedTuple):
    """One support phase on the sample grid.

    Attributes:
        support: ``DOUBLE_SUPPORT`` (0), ``LEFT_SUPPORT`` (1, right foot swinging) or ``RIGHT_SUPPORT`` (2).
        first: index of the phase's first sample.
        count: number of samples (the phase lasts ``count * dt`` s).
        step: index in the plan's footsteps of the step whose swing this phase is, -1 in double support.
        dt: sample period (s).
    """

    support: int
    first: int
    count: int
    step: int
    dt: float

    @property
    def start(self) -> float:
        """Start time (s)."""
        return self.first * self.dt

    @property
    def duration(self) -> float:
        """Duration (s)."""
        return self.count * self.dt

    @property
    def end(self) -> int:
        """Index of the first sample after the phase (touch-down sample for a single support)."""
        return self.first + self.count


@dataclass(frozen=True)
class ZmpSegments:
    """Piecewise-linear ZMP reference: segment j goes linearly from ``start[j]`` to ``end[j]``.

    Attributes:
        first: (M,) int, first sample of each segment; ``first[0] == 0``.
        count: (M,) int, samples per segment (>= 1); segment j lasts ``count[j] * dt`` s.
        start, end: (M, 2) ZMP at the segment's start and end (m, world xy). ``start[0]`` may be NaN: the CoM
            planner chooses it. ``start[j + 1] == end[j]``.
        phase: (M,) int, index of the phase each segment belongs to.
    """

    first: np.ndarray
    count: np.ndarray
    start: np.ndarray
    end: np.ndarray
    phase: np.ndarray


def build_phases(n_steps: int, first_side: str, n_init: int, n_ss, n_ds, n_final: int,
                 dt: float) -> list[Phase]:
    """Phases of an ``n_steps`` walk, durations given in samples (each >= 1), ``first_side`` swinging first.
    ``n_ss``, ``n_ds``: samples of every single support / double support between two steps (int), or a sequence of
    ``n_steps`` ints, one per step (``n_ds[i]`` follows step i; the last one is unused: ``n_final`` follows the last
    step)."""
    counts = [int(n_ss)] * n_steps if isinstance(n_ss, (int, np.integer)) else [int(c) for c in n_ss]
    ds = [int(n_ds)] * n_steps if isinstance(n_ds, (int, np.integer)) else [int(c) for c in n_ds]
    phases = [Phase(DOUBLE_SUPPORT, 0, n_init, -1, dt)]
    k = n_init
    swing_left = first_side == "left"
    for i in range(n_steps):
        phases.append(Phase(RIGHT_SUPPORT if swing_left else LEFT_SUPPORT, k, counts[i], i, dt))
        k += counts[i]
        last = i == n_steps - 1
        phases.append(Phase(DOUBLE_SUPPORT, k, n_final if last else ds[i], -1, dt))
        k += n_final if last else ds[i]
        swing_left = not swing_left
    return phases


def zmp_segments(phases: list[Phase], footsteps: list[Footstep], left_xy: tuple[float, float],
                 right_xy: tuple[float, float], n_ramp_final: int) -> ZmpSegments:
    """ZMP reference segments for ``build_phases`` output (see the module docstring).

    Args:
        phases: from :func:`build_phases`.
        footsteps: the walk's footsteps, ``footsteps[phase.step]`` lands at the end of single support ``phase``.
        left_xy, right_xy: initial sole centres (m).
        n_ramp_final: samples of the final ZMP ramp to the feet mid-point, ``1 <= n_ramp_final < count`` of
            the final phase.
    """
    feet = {LEFT_SUPPORT: tuple(left_xy), RIGHT_SUPPORT: tuple(right_xy)}
    rows: list[tuple[int, int, tuple[float, float], tuple[float, float], int]] = []
    nan = (math.nan, math.nan)
    last = len(phases) - 1
    for ip, ph in enumerate(phases):
        if ph.support != DOUBLE_SUPPORT:
            centre = feet[ph.support]
            rows.append((ph.first, ph.count, centre, centre, ip))
            fs = footsteps[ph.step]
            feet[LEFT_SUPPORT if fs.side == "left" else RIGHT_SUPPORT] = (fs.x, fs.y)
        elif ip == 0:
            rows.append((ph.first, ph.count, nan, feet[phases[1].support], ip))
        elif ip < last:
            rows.append((ph.first, ph.count, feet[phases[ip - 1].support], feet[phases[ip + 1].support], ip))
        else:
            (lx, ly), (rx, ry) = feet[LEFT_SUPPORT], feet[RIGHT_SUPPORT]
            mid = (0.5 * (lx + rx), 0.5 * (ly + ry))
            rows.append((ph.first, n_ramp_final, feet[phases[ip - 1].support], mid, ip))
            rows.append((ph.first + n_ramp_final, ph.count - n_ramp_final, mid, mid, ip))
    first, count, start, end, owner = zip(*rows)
    return ZmpSegments(np.array(first), np.array(count), np.array(start), np.array(end), np.array(owner))
