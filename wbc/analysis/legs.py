"""The legs' geometric bounds on a step, from the robot's reference posture: how far apart the soles can be in
double support (:func:`leg_reach`) and how high a leg can step (:func:`leg_rise`)."""

from __future__ import annotations

import math

import numpy as np

__all__ = ["leg_reach", "leg_rise"]


def _leg_chain(robot):
    """(model, data at ``q_ref``, left sole frame id, leg joint ids from the sole up to the hip)."""
    import pinocchio as pin  # here, not at the top: `wbc --help` and the first-run notice stay instant

    model = robot.model
    data = model.createData()
    pin.framesForwardKinematics(model, data, robot.q_ref)
    fid = robot.frame_id(robot.left_sole)
    chain = []
    j = model.frames[fid].parentJoint
    while j > 0 and model.joints[j].nq != 7:  # up to the joint under the free flyer (the hip)
        chain.append(j)
        j = model.parents[j]
    return model, data, fid, chain


def leg_reach(robot) -> float:
    """Largest fore-aft distance (m) between the two soles in double support that the legs can span.

    Geometric bound: leg length l (sum of the distances between the joint origins from the hip to the sole
    frame, ``q_ref``) and hip height h above the sole at ``q_ref``; with the hips above the mid-point the
    soles are at most ``2 sqrt(l^2 - h^2)`` apart. A step moves the feet mid-point by the step length, so
    the soles are one step length apart in double support.
    """
    model, data, fid, chain = _leg_chain(robot)
    points = [data.oMf[fid].translation] + [data.oMi[j].translation for j in chain]
    length = float(sum(np.linalg.norm(b - a) for a, b in zip(points[:-1], points[1:])))
    height = float(points[-1][2] - points[0][2])
    return 2.0 * float(np.sqrt(max(length**2 - height**2, 0.0)))


def leg_rise(robot) -> float:
    """Largest step up or down (m) a leg can take: the hip's height above the sole at ``q_ref`` minus the shortest
    hip-to-sole distance the leg folds to, one leg joint at a time moved from ``q_ref`` to either of its URDF
    position limits (the knee's flexion limit, for a humanoid).

    Geometric upper bound: with the hip kept at its standing height over the lower tread, the other sole, beneath
    the hip, can be at most this much higher (the leg folded to its shortest); stepping down, the stance leg folds
    the same way.
    """
    import pinocchio as pin

    model, data, fid, chain = _leg_chain(robot)
    hip = chain[-1]
    height = float(data.oMi[hip].translation[2] - data.oMf[fid].translation[2])
    shortest = math.inf
    for j in chain:
        i = model.joints[j].idx_q
        for limit in (model.lowerPositionLimit[i], model.upperPositionLimit[i]):
            if not math.isfinite(limit):
                continue
            q = robot.q_ref.copy()
            q[i] = limit
            pin.framesForwardKinematics(model, data, q)
            shortest = min(shortest, float(np.linalg.norm(data.oMi[hip].translation - data.oMf[fid].translation)))
    return max(height - shortest, 0.0) if math.isfinite(shortest) else height
