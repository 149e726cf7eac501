"""Acceptance criteria of the main job (``wbc walk``), shared by the CLI exit code and the tests."""

from __future__ import annotations

from wbc.scenarios.framework import Criterion, evaluate

__all__ = ["WALK_CRITERIA", "walk_passes"]

#: From the main-job issue.
WALK_CRITERIA = [
    Criterion("walked distance within 5% of planned", "walked_distance_m", "<=", 0.05,
              minus="planned_distance_m", scale_by="planned_distance_m", floor=0.05 * 1e-9),
    Criterion("stance-foot slip ≤ 1 mm", "max_stance_slip_m", "<=", 1e-3),
    Criterion("CoM tracking error ≤ 5 mm", "max_com_error_m", "<=", 5e-3),
    Criterion("ZMP of the executed motion inside the support polygon", "min_zmp_margin_m", ">=", 0.0),
    Criterion("no joint position limit violation", "joint_position_violations", "==", 0),
    Criterion("no joint velocity limit violation", "joint_velocity_violations", "==", 0),
    Criterion("no solver failure", "solver_failures", "==", 0),
    Criterion("no NaN", "nan", "==", False),
]


def walk_passes(summary: dict) -> tuple[bool, list[str]]:
    """(all criteria hold, descriptions of the failed ones)."""
    return evaluate(summary, WALK_CRITERIA)
