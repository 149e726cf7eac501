"""Floating-base state estimation from the sensors a humanoid carries: joint encoders, a base IMU and ankle
force/torque sensors (:mod:`wbc.estimation.base`); the orientation filter (:mod:`wbc.estimation.attitude`); foot
ground reactions, contact detection and the measured ZMP (:mod:`wbc.estimation.contact`)."""

from wbc.estimation.attitude import ComplementaryAttitudeFilter
from wbc.estimation.base import BaseKalmanFilter, FloatingBaseEstimator, JointStateFilter
from wbc.estimation.contact import ContactDetector, FootForceSensor, zmp_from_wrenches

__all__ = ["ComplementaryAttitudeFilter", "BaseKalmanFilter", "FloatingBaseEstimator", "JointStateFilter", "ContactDetector",
           "FootForceSensor", "zmp_from_wrenches"]
