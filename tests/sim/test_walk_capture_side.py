"""The capture step after the last planned step is taken by the foot whose lift leaves the DCM within reach
(issue 61, record 74).

Trial 402 of push campaign 9412 (``wbc campaign run --kind push --seed 9412``, Talos): 320 N for 0.1 s at 4.454 s
towards 287.8° (right, slightly forward) while the left foot swings its last planned step — a push towards the
stance leg. The left lands next to the right, the right then steps 0.6 m out to the right and lands with the DCM
over its inner half, the feet 0.75 m apart. The capture step that follows (``WalkScenario._start_recovery``) lifted
the foot on the DCM's side — the right, on which the DCM stands — on main 2ea5cc3, leaving the CoP on the left sole
0.6 m from the DCM: the base dropped at 5.46 s. With the side checked on the LIPM
(``WalkSteps._capture_excess``) the left foot steps and the walk ends upright (a hip yaw past its speed limit
later, at the touch-down of the step after: see the test).
"""

from __future__ import annotations

import json

import numpy as np

PUSH_9412_402 = ["sim", "walk", "--steps", "8", "--step-length", "0.25", "--step-duration", "0.6", "--push",
                 "319.69296804972987", "--push-time", "4.454422434811134", "--push-dir", "287.8496754177296",
                 "--push-duration", "0.1", "--plant", "realistic", "--state", "estimated", "--seed", "402"]
PUSH_TIME = 4.454422434811134


def test_capture_step_after_a_wide_step_lifts_the_foot_away_from_the_dcm_and_stays_up(cli, tmp_path):
    """The run completes with no fall. At each sole the controller releases after the push, the plant's DCM (its CoM
    plus the finite-difference velocity over ω = √(g / z₀)) is measured against both soles; at the first release with
    the soles more than 0.5 m apart — the capture step after the wide one — the DCM is more than 0.35 m nearer the
    sole that stays than the one lifted (0.52 m measured; on 2ea5cc3 it was 0.42 m nearer the sole lifted).

    What it does not pass (measured in the suite's arithmetic, ``TEST_CPU`` in conftest, with the ID kernel's dense
    active set of record 86): the walk ends 0.56 m off its line and turned 5.6°, which the criteria on the walked
    distance and the final heading count; the capture step's landed sole slides 44.3 mm while the other foot closes
    (5 mm allowed; 39.5 mm with record 85's block active set, 50.1 mm on record 81's AVX-512 machine, 14.7 mm with the
    step time held); a landing slides 14.4 mm (10 mm allowed; 9.9 mm with the block active set); and the right foot
    then steps 0.45 m further out, after whose touch-down the right hip yaw passes its speed limit: 1.030×, 6 ticks
    (1.043×, 6 ticks with the block active set; natively on an AVX-512 znver4, 1.0004×, 1 tick; on record 81's
    machine none; record 79, without AVX-512 and with the step time held: ``leg_left_5``, 1.026×). The speed
    criterion is a failure of this push, left open (issue 61); the test holds it to that joint and within 1.06× its
    limit, and the landing slide within 20 mm, so that a worse one is seen."""
    log, out = tmp_path / "w.npz", tmp_path / "w.json"
    code, err, _ = cli(PUSH_9412_402 + ["--quiet", "--log", str(log), "--json", str(out)])
    s = json.loads(out.read_text())
    d = np.load(log)
    t, com, sole, active = d["t"], d["com"], d["sole_pos"], d["contact_active"].astype(bool)
    xi = com[:, :2] + np.gradient(com, t, axis=0)[:, :2] / np.sqrt(9.81 / com[0, 2])
    i0 = int(np.searchsorted(t, PUSH_TIME))
    i, j = next((i, j) for i in range(i0, len(t)) for j in range(2) if active[i - 1, j] and not active[i, j]
                and np.linalg.norm(sole[i, 0, :2] - sole[i, 1, :2]) > 0.5)
    lifted = np.linalg.norm(xi[i] - sole[i, j, :2])
    stays = np.linalg.norm(xi[i] - sole[i, 1 - j, :2])
    assert lifted - stays > 0.35, (t[i], j, lifted, stays)
    assert not s["fell"] and s["completed"], s["failed_criteria"]
    assert s["joint_speed_exceedances"] <= 10 and s["max_joint_speed_ratio"] <= 1.06, s["failed_criteria"]
    assert s["joint_speed_exceedances"] == 0 or s["max_joint_speed_joint"] == "leg_right_1_joint", s["failed_criteria"]
    failed = [c.split(":")[0] for c in s["failed_criteria"]]
    assert code == 1 and "walked distance within 5% (≥ 1 cm) of the target" in failed, (err, failed)
    assert set(failed) <= {"walked distance within 5% (≥ 1 cm) of the target", "final heading within 5 deg of commanded",
                           "stance slip ≤ 5 mm", "no joint above its URDF velocity limit", "landing slide ≤ 10 mm"}, failed
    assert s["max_landing_slide_m"] <= 0.02 and s["solver_failures"] == 0, s["failed_criteria"]
