""":mod:`wbc.gait.stabilizer`: the DCM stabilizer without a simulator — its compiled step against the class, bit for bit,
and its support-area kernel against :mod:`wbc.geometry` (an independent hull, margin and projection)."""

import numpy as np


def test_support_kernel_matches_the_geometry_helpers():
    """The stabilizer's support-area kernel (hull of the soles' corners, margin and closest point of a CoP) gives the
    numbers of wbc.geometry's convex_hull / polygon_margin / closest_point_in_polygon on the soles'
    projected_sole_corners, for one and two slightly tilted soles and points inside and outside."""
    from wbc.geometry import closest_point_in_polygon, convex_hull, polygon_margin, projected_sole_corners
    import pinocchio as pin

    from wbc.gait.stabilizer import support_kernel

    rng = np.random.default_rng(7)
    length, width = 0.2, 0.1
    corners = np.array([[0.1, 0.05, 0.0], [-0.1, 0.05, 0.0], [-0.1, -0.05, 0.0], [0.1, -0.05, 0.0]])
    n_out = 0
    for _ in range(300):
        soles = [pin.SE3(pin.rpy.rpyToMatrix(*rng.normal(scale=[0.05, 0.05, 0.5])),
                         np.r_[rng.normal(scale=0.2, size=2), 0.0]) for _ in range(rng.integers(1, 3))]
        hull = convex_hull(np.vstack([projected_sole_corners(M, length, width) for M in soles]))
        xy = corners @ np.hstack([M.rotation.T for M in soles])
        t = [M.translation for M in soles] + [np.zeros(3)]
        p = rng.normal(scale=0.25, size=2)
        m, margin, qx, qy = support_kernel(xy, t[0][0], t[0][1], t[1][0], t[1][1], len(soles), p[0], p[1])
        assert m == len(hull)
        # the hull's edge normals and the projection onto an edge sum their products in another order than numpy's
        # (whose kernels depend on the CPU: 1-ulp differences on an AVX-512 host): 4 ulp of the geometry's scale (m)
        assert abs(margin - polygon_margin(p, hull)) <= 4 * np.finfo(float).eps
        assert np.abs(np.subtract((qx, qy), closest_point_in_polygon(p, hull))).max() <= 4 * np.finfo(float).eps
        n_out += margin < 0
    assert 10 < n_out < 290  # both branches exercised


def test_stabilizer_kernel_matches_the_stabilizer():
    """The compiled stabilizer step (DCM law, projection on the soles' hull, integral, CMP offset) gives
    DcmStabilizer's numbers bit for bit — the CoM acceleration, the integral, the projected CoP and the CMP, with
    and without the measured CoP's feedback —
    with the support hull from wbc.geometry's convex_hull of the soles' projected_sole_corners, for one and two
    tilted soles, references inside and outside the hull, with and without the hip strategy and the integral clip."""
    import pinocchio as pin

    from wbc.geometry import convex_hull, projected_sole_corners
    from wbc.gait.stabilizer import DcmStabilizer, stabilizer_kernel

    rng = np.random.default_rng(11)
    length, width = 0.2, 0.1
    corners = np.array([[0.1, 0.05, 0.0], [-0.1, 0.05, 0.0], [-0.1, -0.05, 0.0], [0.1, -0.05, 0.0]])
    n_sat = n_clip = 0
    for it in range(400):
        soles = [pin.SE3(pin.rpy.rpyToMatrix(*rng.normal(scale=[0.05, 0.05, 0.5])),
                         np.r_[rng.normal(scale=0.1, size=2), rng.normal(scale=0.01)])
                 for _ in range(rng.integers(1, 3))]
        hull = convex_hull(np.vstack([projected_sole_corners(M, length, width) for M in soles]))
        xy = corners @ np.hstack([M.rotation.T for M in soles])
        t = [M.translation.copy() for M in soles] + [soles[0].translation.copy()]
        stab = DcmStabilizer(3.2 + rng.uniform(), k_xi=rng.uniform(0, 4), k_i=rng.uniform(0, 2),
                             i_max=rng.uniform(0.001, 0.05), dt=0.002, cmp_offset=(0.0, 0.04)[it % 2],
                             k_z=(0.0, 0.5)[it // 2 % 2])
        stab.integral[:] = stab.i_max * rng.choice([-1.0, 1.0], 2) * rng.uniform(0.999, 1.0, 2)  # near the clip
        o = soles[0].translation[:2]
        refs = o + rng.normal(scale=0.03, size=(2, 3, 2))  # (dcm, zmp) references at samples 0..2
        c, cd = np.r_[o + rng.normal(scale=0.03, size=2), 0.9], np.r_[rng.normal(scale=0.05, size=2), 0.0]
        k = int(rng.integers(0, 3))
        p_meas = None if it % 3 == 0 else o + rng.normal(scale=0.03, size=2)
        integral, last_cop, last_cmp = stab.integral.copy(), np.zeros(2), np.zeros(2)
        law = (*stab.law()[:7], integral, last_cop, last_cmp)
        m, ax, ay, sat = stabilizer_kernel(xy, len(soles), t[0], t[1], c, cd, refs[0, k], refs[1, k],
                                           np.full(2, np.nan) if p_meas is None else p_meas, law)
        i0 = stab.integral.copy()
        acc = stab(c[:2], cd[:2], refs[0, k], refs[1, k], hull, p_meas)
        assert m == len(hull)
        assert (ax, ay) == tuple(acc) and sat == stab.saturated
        assert np.array_equal(integral, stab.integral) and np.array_equal(last_cop, stab.last_cop)
        assert np.array_equal(last_cmp, stab.last_cmp)
        n_sat += sat
        n_clip += (not sat) and np.abs(stab.integral).max() == stab.i_max and np.abs(i0).max() < stab.i_max
    assert 20 < n_sat < 380 and n_clip > 5  # saturated and free, clipped integral: every branch exercised
