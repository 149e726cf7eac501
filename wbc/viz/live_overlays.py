"""What the live viewer draws over each displayed pose, computed in its display thread (never in the control loop).

:class:`LiveOverlays` turns the poses the viewer displays (about 25 per second) into overlays, with the same
names and colours as the HTML recordings (:mod:`wbc.viz.overlays`), each under its own meshcat path
``/meshcat/overlays/<name>`` (toggled in meshcat's "Open Controls" panel):

* points: ``com`` (CoM of the displayed q, Pinocchio), ``com_ground`` (its ground projection), ``dcm_executed``
  (ξ = c + ċ/ω, ω = sqrt(g / c_z), Englsberger et al. 2015 eq. 7, ċ by a backward difference over the last two
  displayed poses), ``zmp_executed`` (cart-table ZMP p = c_xy − c_z/g · c̈_xy, Kajita et al. 2003 eq. 3, c̈ by
  the second difference of the last three displayed poses, so it is one displayed frame late); with a
  walk plan also ``zmp_planned`` and ``dcm_planned`` at the displayed time;
* ``support_polygon``: hull of the soles in contact (from the plan's support phase, or without a plan the
  soles whose origin is within ``contact_height`` of the ground), re-sent when the support changes;
* ``footprints``: sole outline of each foot at the start and wherever it touches down (with a plan, every
  touch-down of the plan's samples since the previous displayed frame: the displayed sole if it is still down,
  else the plan's sole pose at that touch-down — frames skipped by a starved display thread lose none);
* ``swing_left`` / ``swing_right``: the path of each sole origin so far (re-sent every ``trail_every`` frames);
* static, once: ``footsteps_planned`` (the plan's footsteps).
"""

from __future__ import annotations

import math

import numpy as np
import pinocchio as pin

from wbc.geometry import convex_hull, sole_polygon
from wbc.robot import Robot

__all__ = ["LiveOverlays"]

_LEFT_DOWN, _RIGHT_DOWN = (0, 1), (0, 2)  # support codes with the left / right foot on the ground


def _outline(pose: np.ndarray, length: float, width: float, z: float = 0.002) -> np.ndarray:
    xy = sole_polygon(pose[0, 3], pose[1, 3], math.atan2(pose[1, 0], pose[0, 0]), length, width)
    return np.c_[xy, np.full(len(xy), z)]


class LiveOverlays:
    """Overlays of the live viewer for one run (one instance per run; used by one display thread).

    Args:
        robot: the robot (sole frames ``robot.left_sole`` / ``robot.right_sole`` and sole rectangle).
        plan: optional :class:`wbc.gait.WalkPlan` on the clock of the times given to :meth:`frame`, or a
            function returning it (or None) when asked, for a plan made once the run has started.
        contact_height: without a plan, a sole whose origin is at most this high (m) is in contact.
        trail_every: swing paths are re-sent every this many frames (and at each touchdown).
    """

    def __init__(self, robot: Robot, plan=None, *, contact_height: float = 0.005, trail_every: int = 5):
        self.robot = robot
        self.plan = plan
        self.contact_height = float(contact_height)
        self.trail_every = max(1, int(trail_every))
        self._data = robot.model.createData()
        self._frames = (robot.frame_id(robot.left_sole), robot.frame_id(robot.right_sole))
        self._history: list[tuple[float, np.ndarray]] = []  # (t, CoM) of the last three frames
        self._support: int | None = None
        self._trails: tuple[list, list] = ([], [])
        self._count = 0
        self._k: int | None = None  # plan sample of the last frame, and that plan (touch-downs between frames)
        self._k_plan = None

    def _plan(self):
        return self.plan() if callable(self.plan) and not hasattr(self.plan, "index") else self.plan

    def static(self) -> dict[str, list[np.ndarray]]:
        """Closed outlines drawn once: ``{"footsteps_planned": [(4, 3), ...]}`` with a plan, else ``{}``."""
        plan = self._plan()
        if plan is None:
            return {}
        L, W = self.robot.sole_length, self.robot.sole_width
        return {"footsteps_planned": [_outline(f.pose(), L, W) for f in plan.footsteps]}

    def frame(self, q: np.ndarray, t: float | None) -> dict:
        """Overlays of one displayed pose ``q`` (nq,) at time ``t`` (s, or None).

        Returns:
            ``{"points": {name: (3,)}, "support_polygon": (K, 3), (0, 3) to hide it, or None (unchanged),
            "footprints": [new (4, 3)
            outlines], "trails": {name: (K, 3)} (only when re-sent)}``, world frame, m.
        """
        model, data, robot = self.robot.model, self._data, self.robot
        pin.framesForwardKinematics(model, data, q)
        com = pin.centerOfMass(model, data, q, False).copy()
        soles = [data.oMf[f].homogeneous for f in self._frames]
        points = {"com": com, "com_ground": np.array([com[0], com[1], 0.0])}
        if t is not None:
            if self._history and t <= self._history[-1][0]:
                self._history.clear()  # time went back (a new run): restart the differences
            self._history = [*self._history[-2:], (float(t), com)]
            g = robot.gravity
            omega = math.sqrt(g / max(com[2], 1e-3))
            if len(self._history) >= 2:
                (t1, c1), (t2, c2) = self._history[-2:]
                vel = (c2 - c1) / (t2 - t1)
                points["dcm_executed"] = np.array([com[0] + vel[0] / omega, com[1] + vel[1] / omega, 0.0])
            if len(self._history) == 3:
                (t0, c0), (t1, c1), (t2, c2) = self._history
                acc = 2.0 * ((c2 - c1) / (t2 - t1) - (c1 - c0) / (t1 - t0)) / (t2 - t0)
                points["zmp_executed"] = np.array([c1[0] - c1[2] / g * acc[0],
                                                   c1[1] - c1[2] / g * acc[1], 0.0])
        plan = self._plan()
        touches = None  # with a plan: the touch-downs (foot, sample) of every sample since the last frame
        if plan is not None and t is not None:
            k = plan.index(t)
            points["zmp_planned"] = np.array([*plan.zmp[k], 0.0])
            points["dcm_planned"] = np.array([*plan.dcm[k], 0.0])
            support = int(plan.support[k])
            if self._k_plan is plan and self._k is not None and k >= self._k:
                # the display thread shows the latest pose only (frames are skipped when it is starved, e.g. on a
                # loaded machine): a touch-down between two displayed frames still gets its footprint
                sup = plan.support
                touches = [(j, i) for i in range(self._k + 1, k + 1)
                           for j, codes in enumerate((_LEFT_DOWN, _RIGHT_DOWN))
                           if int(sup[i]) in codes and int(sup[i - 1]) not in codes]
            self._k, self._k_plan = k, plan
        else:
            down = [s[2, 3] <= self.contact_height for s in soles]
            support = 0 if all(down) else 1 if down[0] else 2 if down[1] else 3
            self._k = self._k_plan = None
        out: dict = {"points": points, "support_polygon": None, "footprints": [], "trails": {}}
        L, W = robot.sole_length, robot.sole_width
        touchdown = False
        for j, codes in enumerate((_LEFT_DOWN, _RIGHT_DOWN)):
            self._trails[j].append(soles[j][:3, 3].copy())
            if touches is None:
                was = self._support in codes if self._support is not None else False
                if support in codes and not was:
                    out["footprints"].append(_outline(soles[j], L, W))
                    touchdown = True
                continue
            mine = [i for jj, i in touches if jj == j]
            for n, i in enumerate(mine):
                # the realized sole (the displayed one) if it is still down since its last touch-down, else the
                # plan's sole pose at that touch-down (its stance was not displayed)
                last_down = n == len(mine) - 1 and support in codes
                pose = soles[j] if last_down else (plan.left_sole if j == 0 else plan.right_sole)[i]
                out["footprints"].append(_outline(pose, L, W))
                touchdown = True
        if support != self._support:
            polys = [_outline(soles[j], L, W)[:, :2] for j, codes in enumerate((_LEFT_DOWN, _RIGHT_DOWN))
                     if support in codes]
            if polys:
                hull = polys[0] if len(polys) == 1 else convex_hull(np.vstack(polys))
                out["support_polygon"] = np.c_[hull, np.full(len(hull), 0.003)]
            else:
                out["support_polygon"] = np.zeros((0, 3))  # no contact: hide it
            self._support = support
        self._count += 1
        if (touchdown or self._count % self.trail_every == 0) and len(self._trails[0]) >= 2:
            out["trails"] = {"swing_left": np.array(self._trails[0]), "swing_right": np.array(self._trails[1])}
        return out
