"""Kinematic tasks: each knows its error e(q), its Jacobian J(q), a gain and per-row weights."""

from wbc.tasks.base import Task
from wbc.tasks.com import ComTask
from wbc.tasks.frame import FrameTask, OrientationTask, PositionTask
from wbc.tasks.posture import PostureTask

__all__ = ["Task", "ComTask", "FrameTask", "OrientationTask", "PositionTask", "PostureTask"]
