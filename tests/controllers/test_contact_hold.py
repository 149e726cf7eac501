"""The contact hold's objects against independent references: :class:`DriftMeter` against the contact frame placed
by :class:`~wbc.configuration.Configuration` at pin.integrate(q, v dt) (closed form: a frame held where it is must
end where it was), :class:`ContactRange` against the pseudo-inverse projector J_c J_c⁺."""

from __future__ import annotations

import numpy as np
import pinocchio as pin

from wbc.configuration import Configuration
from wbc.constraints import ContactConstraint
from wbc.controllers.contact_hold import ContactRange, DriftMeter

DT = 0.002


def _held_soles(robot, config):
    contacts = [ContactConstraint(robot, f) for f in (robot.left_sole, robot.right_sole)]
    for c in contacts:
        c.set_placement_from_configuration(config)  # e = 0: each row sends its frame where it is
    return contacts


def test_drift_is_where_the_frame_ends_from_where_it_is_held(robots):
    """e = 0 (each sole held where it is): the drift is the distance the sole moves over the tick, read from a
    Configuration at q⁺ (its own forward kinematics), and with a lever the larger of that and lever × its turn."""
    robot = robots("talos")
    config = Configuration(robot)
    contacts = _held_soles(robot, config)
    meter = DriftMeter(robot.model)
    assert meter.measure(config, np.zeros(robot.model.nv), DT, contacts, 0.0)[2] <= 1e-15
    rng = np.random.default_rng(3)
    v = rng.normal(size=robot.model.nv) * 0.5
    after = Configuration(robot, pin.integrate(robot.model, config.q, v * DT))
    moved = [after.frame_placement(c.frame_id).translation - c.placement.translation for c in contacts]
    turned = [np.linalg.norm(pin.log3(c.placement.rotation.T @ after.frame_placement(c.frame_id).rotation))
              for c in contacts]
    far, drifts, worst = meter.measure(config, v, DT, contacts, 0.0)
    distance = max(np.linalg.norm(m) for m in moved)
    assert distance > 1e-4  # the random command moves the soles: the check is not vacuous
    assert abs(far - distance) <= 1e-12 and abs(worst - distance) <= 1e-12
    assert len(drifts) == 2 and all(d.shape == (6,) for d in drifts)
    lever = 1.0 / 6.0
    _, _, worst = meter.measure(config, v, DT, contacts, lever)
    expected = max(max(np.linalg.norm(m), lever * t) for m, t in zip(moved, turned))
    assert abs(worst - expected) <= 1e-12 * max(1.0, expected)


def test_drift_of_a_displaced_sole_against_its_corrected_target(robots):
    """A sole held 1 cm away (e ≠ 0) and v = 0: the frame stays, its row sends it (1 − K dt) of the way back, so the
    distance is K dt × 1 cm (closed form, translation only)."""
    robot = robots("talos")
    config = Configuration(robot)
    contacts = _held_soles(robot, config)
    c = contacts[0]
    c.placement = c.placement * pin.SE3(np.eye(3), np.array([0.01, 0.0, 0.0]))
    far, _, _ = DriftMeter(robot.model).measure(config, np.zeros(robot.model.nv), DT, contacts, 0.0)
    assert abs(far - c.gain * DT * 0.01) <= 1e-12


def test_remembered_until_forgotten(robots):
    robot = robots("talos")
    config = Configuration(robot)
    contacts = _held_soles(robot, config)
    meter = DriftMeter(robot.model)
    v = np.full(robot.model.nv, 0.1)
    first = meter.measure(config, v, DT, contacts, 0.0, remember=True)
    contacts[0].placement = contacts[0].placement * pin.SE3(np.eye(3), np.array([0.05, 0.0, 0.0]))
    kept = meter.measure(config, v, DT, contacts, 0.0)
    assert kept[0] == first[0] and kept[1][0] is first[1][0]  # the same v, q and dt: the answer kept
    meter.forget()
    assert meter.measure(config, v, DT, contacts, 0.0)[0] > first[0] + 0.009  # K dt × 5 cm = 1 cm more


def test_range_basis_projects_like_the_pseudo_inverse():
    """Two equal rows (a dependent pair) and a third: the basis has rank 2 and U_r U_rᵀ = J J⁺ (numpy pinv)."""
    rng = np.random.default_rng(1)
    J = rng.normal(size=(3, 8))
    J[1] = J[0]
    rng_ = ContactRange()
    basis = rng_.basis(J, 1e-3)
    assert basis.shape == (3, 2)
    np.testing.assert_allclose(basis @ basis.T, J @ np.linalg.pinv(J, rcond=1e-10), atol=1e-12)
    full = rng_.basis(rng.normal(size=(3, 8)), 1e-3)
    assert full.shape == (3, 3)
    np.testing.assert_allclose(full.T @ full, np.eye(3), atol=1e-12)


def test_range_svd_kept_while_the_rows_are_unchanged(monkeypatch):
    J = np.arange(12.0).reshape(3, 4)
    rng_ = ContactRange()
    svd, calls = np.linalg.svd, []
    monkeypatch.setattr(np.linalg, "svd", lambda *a, **k: calls.append(1) or svd(*a, **k))
    basis = rng_.basis(J, 1e-3)
    assert rng_.basis(J.copy(), 1e-3).base is basis.base and len(calls) == 1  # equal rows: the same factors
    J2 = J.copy()
    J2[0, 0] += 1.0
    rng_.basis(J2, 1e-3)
    assert len(calls) == 2
    S = np.linalg.svd(J, compute_uv=False)
    assert basis.shape == (3, int(np.sum(S > 1e-3 * S[0])))
