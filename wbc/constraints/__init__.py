"""Constraints of both QP levels, one protocol (:class:`~wbc.constraints.base.Constraint`: name, kind, dim,
relaxable, ``write``; :mod:`wbc.constraints.base`), one module per concept.

Kinematic level (rows in v, exported here): contacts (:mod:`~wbc.constraints.contact`), hard tasks
(:mod:`~wbc.constraints.task`), joint position / velocity / braking / acceleration limits (:mod:`~wbc.constraints.limits`,
:mod:`~wbc.constraints.braking`, :mod:`~wbc.constraints.acceleration`), CoM polygon, executed ZMP, self-collision.

Inverse-dynamics level (rows in x = [v̇; f] (nv + 12 n_c), :mod:`wbc.formulations.acceleration`; its equations
eq. 4–9). The formulation gives each constraint its place once (``rows`` / ``indices``); per tick ``write`` writes the
numbers in place into the preallocated arrays, so no matrix is rebuilt and a constant block (the friction pyramids)
is written only once. The rows that depend on the state are written by one compiled (numba) body each, called by
the constraint's ``write`` (the general assembly, :meth:`~wbc.formulations.acceleration.InverseDynamicsQP.build`)
and by the compiled tick (:func:`wbc.formulations.idkernel.id_assemble`) alike: both paths solve one problem,
written by one formula.

============================  ==========  ===============================================================  ===========
name                          kind        rows                                                             relaxable
============================  ==========  ===============================================================  ===========
``floating_base_dynamics``    equality    M_u v̇ − (J_cᵀ)_u f = −h_u (eq. 4)                                no
``contact:<c>``               equality    J_k v̇ = −J̇_k v − K_d J_k v − K_p e_k, active contacts (eq. 5)     no
``task:<t>``                  equality    a hard acceleration task J v̇ = a* − J̇ v                          no
``torque_limits``             inequality  −τ_max − h_a ≤ M_a v̇ − (J_cᵀ)_a f ≤ τ_max − h_a (eq. 6)           yes
``friction:<c>``              inequality  friction pyramid F_k f_k ≤ 0 (eq. 7) while active, else free      no
``unilaterality:<c>``         bounds      min(f_min, f_max) ≤ f_z ≤ f_max per corner (CoP inside the       no
                                          sole), or f_k = 0 when the contact is inactive (eq. 8)
``joint_limits``              bounds      joint position / velocity / viability bounds on v̇ (eq. 9)        yes
``<name of the kinematic      inequality  second-order barrier G v̇ ≥ −Ġv − 2γ G v − γ² h of a kinematic      as the
constraint>``                             constraint's h(q) ≥ 0 (:class:`AccelerationBarrier`: ``com_polygon``,  kinematic
                                          ``self_collision``)                                                 one
============================  ==========  ===============================================================  ===========

Modules: :mod:`~wbc.constraints.floating_base`, :mod:`~wbc.constraints.contact_acceleration`,
:mod:`~wbc.constraints.hard_task`, :mod:`~wbc.constraints.torque_limits`, :mod:`~wbc.constraints.friction`,
:mod:`~wbc.constraints.unilaterality`, :mod:`~wbc.constraints.joint_acceleration_bounds`,
:mod:`~wbc.constraints.barrier`, :mod:`~wbc.constraints.joint_velocity` (joint speed bounds, kept in the relaxed
solve). Added by the user (``InverseDynamicsQP.add_constraint``, exported here): a bound on the centroidal angular
momentum rate, |L̇| ≤ L̇_max (:mod:`~wbc.constraints.momentum_rate`, relaxable); a bound on a frame origin's linear
acceleration, |p̈| ≤ a_max (:mod:`~wbc.constraints.frame_acceleration`, relaxable); the legs' joint speeds after
the impact of a sole about to touch down (:mod:`~wbc.constraints.impact`, relaxable). *Relaxable* constraints are the
ones a controller drops when the full QP is infeasible (kinematic: ``TickResult.relaxed``; inverse dynamics:
:meth:`~wbc.formulations.acceleration.InverseDynamicsQP.solve_relaxed`).
"""

from wbc.constraints.acceleration import JointAccelerationLimit
from wbc.constraints.base import BoxConstraint, Constraint, EqualityConstraint, InequalityConstraint
from wbc.constraints.com_polygon import ComPolygonConstraint
from wbc.constraints.contact import ContactConstraint
from wbc.constraints.frame_acceleration import FrameAccelerationBound
from wbc.constraints.impact import ImpactSpeedBounds
from wbc.constraints.limits import JointPositionLimit, JointVelocityLimit
from wbc.constraints.momentum_rate import AngularMomentumRateBound
from wbc.constraints.self_collision import SelfCollisionConstraint
from wbc.constraints.task import TaskConstraint

__all__ = [
    "AngularMomentumRateBound", "BoxConstraint", "Constraint", "EqualityConstraint", "InequalityConstraint",
    "ComPolygonConstraint", "ContactConstraint", "FrameAccelerationBound", "ImpactSpeedBounds",
    "JointAccelerationLimit", "JointPositionLimit", "JointVelocityLimit", "SelfCollisionConstraint", "TaskConstraint",
]
