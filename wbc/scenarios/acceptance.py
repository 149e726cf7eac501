"""Acceptance criteria of the main job, shared by the CLI exit code and the tests."""

from __future__ import annotations

__all__ = ["WALK_CRITERIA", "walk_passes"]

#: (summary key, description, predicate) — from the main-job issue.
WALK_CRITERIA = [
    ("walked_distance_m", "walked distance within 5% of planned",
     lambda s: abs(s["walked_distance_m"] - s["planned_distance_m"]) <= 0.05 * max(s["planned_distance_m"], 1e-9)),
    ("max_stance_slip_m", "stance-foot slip ≤ 1 mm", lambda s: s["max_stance_slip_m"] <= 1e-3),
    ("max_com_error_m", "CoM tracking error ≤ 5 mm", lambda s: s["max_com_error_m"] <= 5e-3),
    ("min_zmp_margin_m", "ZMP of the executed motion inside the support polygon", lambda s: s["min_zmp_margin_m"] >= 0.0),
    ("joint_position_violations", "no joint position limit violation", lambda s: s["joint_position_violations"] == 0),
    ("joint_velocity_violations", "no joint velocity limit violation", lambda s: s["joint_velocity_violations"] == 0),
    ("solver_failures", "no solver failure", lambda s: s["solver_failures"] == 0),
    ("nan", "no NaN", lambda s: not s["nan"]),
]


def walk_passes(summary: dict) -> tuple[bool, list[str]]:
    """(all criteria hold, descriptions of the failed ones)."""
    failed = [desc for _, desc, ok in WALK_CRITERIA if not ok(summary)]
    return not failed, failed
