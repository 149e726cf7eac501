"""Kinematic tasks: each knows its error e(q), its Jacobian J(q), a gain and per-row weights."""

from wbc.tasks.base import Task
from wbc.tasks.com import ComTask
from wbc.tasks.damping import DampingTask
from wbc.tasks.frame import FrameTask, OrientationTask, PositionTask
from wbc.tasks.momentum import AngularMomentumTask
from wbc.tasks.posture import PostureTask
from wbc.tasks.relative_frame import RelativeFrameTask

__all__ = ["Task", "AngularMomentumTask", "ComTask", "DampingTask", "FrameTask", "OrientationTask", "PositionTask",
           "PostureTask", "RelativeFrameTask"]
