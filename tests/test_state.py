"""DynamicsState.update: the input checks of (q, v) — the one-call check on float arrays and the full checks that
name what fails — accept and refuse the same inputs."""

from __future__ import annotations

import numpy as np
import pytest

from wbc.exceptions import ConfigurationError
from wbc.state import DynamicsState


def test_update_accepts_and_refuses_the_same_inputs_on_every_input_form(robots):
    robot = robots("talos")
    st = DynamicsState(robot)
    nq, nv = robot.model.nq, robot.model.nv
    q0, v0 = robot.q_ref.copy(), np.linspace(-0.1, 0.1, nv)

    def forms(q, v):
        # float C arrays (the one-call check), lists and a strided view (the full checks)
        strided = np.repeat(v, 2)[::2]
        return ((q, v), (list(q), list(v)), (q.copy(), strided))

    for q, v in forms(q0, v0):
        st.update(q, v)
        np.testing.assert_array_equal(np.asarray(st.q), q0)
        np.testing.assert_array_equal(np.asarray(st.v), v0)
    # |‖quat‖² − 1| ≤ 1e-6 is accepted, beyond it refused
    scale_ok, scale_bad = np.sqrt(1.0 + 0.9e-6), np.sqrt(1.0 + 1.1e-6)
    ok = q0.copy()
    ok[3:7] *= scale_ok
    st.update(ok, v0)
    bad_inputs = []
    for i, value in ((0, np.nan), (nq - 1, np.inf)):
        q = q0.copy()
        q[i] = value
        bad_inputs.append(((q, v0), "configuration q must be finite"))
    v = v0.copy()
    v[nv - 1] = -np.inf
    bad_inputs.append(((q0, v), "velocity v must be finite"))
    bad_inputs.append(((q0[:-1], v0), "configuration q must have shape"))
    bad_inputs.append(((q0, v0[:-1]), "velocity v must have shape"))
    q = q0.copy()
    q[3:7] *= scale_bad
    bad_inputs.append(((q, v0), "base quaternion q[3:7] must have unit norm"))
    for (q, v), text in bad_inputs:
        for qf, vf in forms(q, v):
            with pytest.raises(ConfigurationError, match=text.replace("[", r"\[").replace("]", r"\]")):
                st.update(qf, vf)


def test_frames_placed_on_read_after_every_update(robots):
    """After each update, every frame placement read through ``data`` (or ``frame_placement``) is Pinocchio's
    ``updateFramePlacements`` at that q, also when per-tick readers placed some frames through ``getFrameJacobian``
    on ``kinematics_data`` in between (a frame placed then must not stop the others from being placed)."""
    import pinocchio as pin

    for name in ("talos", "g1"):
        robot = robots(name)
        model = robot.model
        ref = model.createData()
        rng = np.random.default_rng(5)
        state = DynamicsState(robot)
        for step in range(3):
            q = pin.randomConfiguration(model, -np.ones(model.nq), np.ones(model.nq)) if step else robot.q_ref.copy()
            v = rng.normal(size=model.nv)
            state.update(q, v)
            pin.getFrameJacobian(model, state.kinematics_data, model.nframes - 1, pin.LOCAL)
            pin.framesForwardKinematics(model, ref, q)
            for f in range(model.nframes):
                np.testing.assert_array_equal(state.data.oMf[f].homogeneous, ref.oMf[f].homogeneous)
                np.testing.assert_array_equal(state.frame_placement(f).homogeneous, ref.oMf[f].homogeneous)
