"""MuJoCo model of a :class:`~wbc.robot.Robot`, compiled at run time from the same URDF as the Pinocchio model.

:func:`build_mujoco_model` loads the URDF text (``package://`` and relative mesh paths made absolute) into
``mujoco.MjSpec`` with ``<compiler fusestatic="false" discardvisual="false" strippath="false"
inertiafromgeom="false" balanceinertia="false"/>`` (without ``fusestatic="false"`` the jointless root link is
merged into the world and Talos loses 13.5 kg), then edits the spec:

* a free joint ``root_joint`` on the root body (the URDF root link, whose body frame is Pinocchio's root joint
  frame), a ground plane ``floor`` (z = 0, priority 1 so its friction is the contact friction);
* one ``motor`` actuator per actuated joint, named like the joint, created in **Pinocchio's joint order** (so
  ``ctrl[i]`` is the torque of Pinocchio's ``v[6 + i]``), gear 1, ctrlrange = forcerange = ± URDF effort limit
  (unlimited when the URDF limit is 0 or inf);
* feet (``foot_contact="box"``): the collision geoms of every body rigidly attached to a sole frame are removed
  and replaced by one box ``{left,right}_foot_box`` whose bottom face is the sole rectangle
  (``sole_length`` × ``sole_width``) at the sole frame; box-on-plane gives 4 corner contacts per flat foot.
  ``"urdf"`` keeps the URDF collision geoms instead (a foot without any collision geom touches the ground
  through its visual geoms, convex hulls, with a warning), and a mesh foot gets massless point contacts (spheres
  of 1 mm, group 3) on the corners of its flat bottom, its vertices within 2 mm of the lowest: MuJoCo's
  plane–mesh collision keeps 4 contacts around the deepest vertex, between which a flat mesh sole rocks
  (``_mesh_sole_pads``). Visual geoms (group 1, no collision) are otherwise kept without collision;
* collision bits: robot collision geoms have ``contype=ROBOT_BIT, conaffinity=ENV_BIT``; the floor has
  ``contype=ENV_BIT, conaffinity=ENV_BIT | ROBOT_BIT``. Hence every robot collision geom touches the floor (a
  non-foot body on the ground means a fall) while robot–robot pairs never collide (default: URDF collision
  meshes of Talos overlap in half_sitting: 23 contacts, ~480 kN). ``self_collision="srdf"`` re-enables
  robot–robot collision minus the SRDF ``disable_collisions`` pairs, ``"all"`` minus MuJoCo's parent–child
  filter only. Objects added later should use the floor's bits to be touched by the robot;
* ``plant="realistic"``: the drive models of :mod:`wbc.sim.actuators` (URDF damping and dry friction, rotor
  armature per robot, torque–speed envelope) are written into the compiled model; the default ``"ideal"`` keeps
  the plant equal to the Pinocchio model as described next;
* joint damping / dry friction: MuJoCo applies URDF ``<dynamics damping friction>`` (Talos upper body: 1 and 1),
  Pinocchio's RNEA/ABA ignore them. Default ``zero_joint_damping_friction=True`` zeroes them in MuJoCo so both
  models have the same dynamics; the URDF values stay available (``joint_damping``, ``joint_friction``) for a
  controller that wants to compensate them after building with ``zero_joint_damping_friction=False``;
* armature = Pinocchio's ``model.armature`` (0 for the catalog robots). To model rotor inertia, set
  ``robot.model.armature[6:]`` before building: both models then keep the same mass matrix. The model itself
  is stable at 2 ms with zero armature, but an explicit joint PD is not on light links (G1 ankle roll and wrist:
  effective inertia ~4e-4 kg·m²): keep ``kd < Ieff / dt`` and ``kp < 0.1 Ieff / dt²`` there, Ieff = 1 / (M⁻¹)ᵢᵢ.
* contact friction: **elliptic friction cones with** ``impratio`` **= 10** (MuJoCo's defaults are pyramidal and 1),
  Newton solver (MuJoCo's default). MuJoCo's contacts are soft by design, friction included: a foot loaded
  tangentially well inside its friction cone still creeps, at a speed proportional to the tangential force over
  the friction impedance (MuJoCo documentation, Overview, "Softness and slip"). A real sole below its friction
  limit does not slide (static friction), so the plant should not either. ``impratio`` is "the ratio of
  frictional-to-normal constraint impedance for elliptic friction cones ... Settings larger than 1 cause friction
  forces to be 'harder' than normal forces, having the general effect of preventing slip, without increasing the
  actual friction coefficient"; "it is not recommended to use high impratio values with pyramidal cones" (XML
  reference, ``option/impratio``), and "using the Newton solver with elliptic friction cones and large value of
  impratio is the recommended way of reducing slip" (Overview, "Softness and slip"). The normal stiffness and the
  friction coefficient are unchanged (stance-sole creep per step on a G1 walk for each cone and impratio:
  ``benchmarks/README.md``, "Measurement history moved out of docstrings");
* foot friction time constant (``friction_timeconst``, default 2 timesteps): a second creep comes from the legs
  moving over a standing foot, and neither impratio nor MuJoCo's noslip solver touch it. A friction row has no
  position term: the solver sets the contact point's ``J·qacc`` to the reference ``-b·v`` with
  ``b = 2 / (dmax · timeconst)`` (``mj_makeImpedance``), and noslip solves the same rows with the regulariser
  removed. The point's acceleration is ``J·qacc + J̇·q̇`` though, and ``J̇·q̇`` (the centripetal and Coriolis
  terms of the leg's joint rates, of the order of 1 m/s² for a knee extending at 2–3 rad/s) is left out, so the
  sole slides at ``v = J̇·q̇ / b`` with any tangential load inside the cone: about 1 cm/s with the contact's own
  0.02 s (b = 105 /s), which a real sole below its friction limit does not do. The foot contacts therefore get
  their friction rows' time constant separately (``solreffriction``, which MuJoCo accepts on explicit contact
  pairs only: :func:`stiff_foot_friction`), at 2 timesteps, the smallest MuJoCo accepts (``b·dt`` ≈ 1: a slip
  velocity is removed within about a step). Their normal rows keep the contact's solref and solimp, the friction
  coefficient is unchanged (a sole pushed past μ·f_n still slides), and contacts of other robot bodies stay
  dynamic. Its effect on a squatting G1: ``tests/sim/test_mujoco_model.py``;
* ground stiffness (``ground_timeconst``, default None: MuJoCo's ``solref`` 0.02 s on every ground geom): the
  normal rows of the ground contacts get ``solref = (ground_timeconst, 1)``, a stiffer ground when smaller (a
  10 kg box rests 0.108 mm deep at 0.02 s, 0.0044 mm at 0.004 s), to test a controller on the grounds it may meet
  (blind rough ground at three stiffnesses: ``benchmarks/records/77-*.md``);
* the foot boxes are in geom group 3 (hidden by default in viewers); URDF collision geoms stay in group 0.
  Joint position limits are enforced by MuJoCo, velocity limits are not.

Conventions (implemented by :class:`wbc.sim.conventions.StateMap`), with R the base rotation (world ← base):

==================  =========================================  ==========================================
quantity            Pinocchio                                  MuJoCo
==================  =========================================  ==========================================
base position       ``q[0:3]`` world (m)                       ``qpos[0:3]`` world (same)
base orientation    ``q[3:7]`` = (x, y, z, w)                  ``qpos[3:7]`` = (w, x, y, z)
joints              ``q[7:]`` Pinocchio tree order             ``qpos[mj_qpos]``, matched by joint name
base linear vel.    ``v[0:3]`` base frame (LOCAL)              ``qvel[0:3] = R v[0:3]`` world frame
base angular vel.   ``v[3:6]`` base frame                      ``qvel[3:6] = v[3:6]`` base frame (same)
joint velocities    ``v[6:]``                                  ``qvel[mj_qvel]``
==================  =========================================  ==========================================

So ``qvel = T(q) v`` with ``T = blockdiag(R, I3, P)`` (P a permutation), ``qacc = T a + Ṫ v`` with
``Ṫ v = [R (ω × v_lin), 0, ...]``, generalized forces ``τ_pin = Tᵀ τ_mj``, ``M_pin = Tᵀ M_mj T`` and
``nle_pin = Tᵀ (qfrc_bias + M_mj Ṫ v)``. Continuous joints (Pinocchio (cos, sin)) map to a hinge angle.
"""

from __future__ import annotations

import re
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path
from typing import Callable

import mujoco
import numpy as np
import pinocchio as pin

from wbc.constants import SIDES
from wbc.exceptions import InvalidInputError, SimulationError
from wbc.geometry import convex_hull
from wbc.robot import Robot
from wbc.robot_inspect import FLAT_BAND
from wbc.sim.actuators import PLANTS, actuator_model, apply_actuators
from wbc.sim.conventions import StateMap
from wbc.sim.meshes import MUJOCO_MESH_SUFFIXES, mujoco_readable
from wbc.sim.mujoco_runtime import MujocoModel

__all__ = ["MujocoModel", "build_mujoco_model", "stiff_foot_friction", "ENV_BIT", "ROBOT_BIT", "MAX_TIMESTEP"]

ENV_BIT = 1  #: contype/conaffinity bit of the environment (floor, obstacles)
ROBOT_BIT = 2  #: contype bit of robot collision geoms
MAX_TIMESTEP = 0.002  #: s
SOLE_PAD_RADIUS = 0.001  #: m, radius of the point contacts on a mesh foot's flat bottom (``_mesh_sole_pads``)


def build_mujoco_model(
    robot: Robot,
    *,
    timestep: float = MAX_TIMESTEP,
    foot_contact: str = "box",
    self_collision: bool | str = False,
    zero_joint_damping_friction: bool = True,
    floor_friction: float = 1.0,
    foot_box_thickness: float = 0.005,
    integrator: str = "implicitfast",
    cone: str = "elliptic",
    impratio: float = 10.0,
    friction_timeconst: float | None = None,
    ground_timeconst: float | None = None,
    customize: Callable[[mujoco.MjSpec], None] | None = None,
    sensors: bool = True,
    plant: str = "ideal",
    terrain=None,
) -> MujocoModel:
    """Compile a MuJoCo model of ``robot`` from its URDF (see the module docstring for every modelling choice).

    Args:
        robot: the robot; its URDF, package dirs, sole frames and sole size are used.
        timestep: integration step (s), 0 < timestep <= 0.002.
        foot_contact: ``"box"`` (sole-rectangle box per foot) or ``"urdf"`` (URDF foot collision geoms).
        self_collision: ``False`` (robot geoms collide with the environment only), ``"srdf"`` (robot–robot
            collision except the SRDF ``disable_collisions`` pairs) or ``"all"``.
        zero_joint_damping_friction: zero URDF joint damping and dry friction in MuJoCo (Pinocchio ignores them).
        floor_friction: sliding friction coefficient of the floor (it overrides the robot geoms' friction).
        foot_box_thickness: height (m) of the foot boxes (they extend from the sole plane up into the foot).
        integrator: MuJoCo integrator name: ``"euler"``, ``"implicitfast"``, ``"implicit"`` or ``"rk4"``.
        cone: friction cone, ``"elliptic"`` (default) or ``"pyramidal"`` (MuJoCo's default; module docstring).
        impratio: ratio of frictional to normal constraint impedance (≥ 1; default 10, MuJoCo's 1).
        friction_timeconst: time constant (s) of the friction rows of the foot contacts (``solreffriction`` of
            explicit contact pairs, :func:`stiff_foot_friction`); None: ``2 * timestep``, the smallest MuJoCo
            accepts; 0: none (the friction rows share the contact's ``solref``, MuJoCo's default). Otherwise it
            must be at least ``2 * timestep``.
        ground_timeconst: time constant (s) of the normal rows of every contact with the ground (``solref``
            ``(ground_timeconst, 1)`` of the floor, the terrain boxes and the heightfield, so of the foot pairs too);
            None: MuJoCo's default 0.02 s. A smaller value is a stiffer ground (a sole sinks less under the same
            load); at least ``2 * timestep``.
        customize: called with the ``MjSpec`` just before compilation (add cameras, lights, obstacles...).
        sensors: add the joint encoders, the pelvis IMU and the ankle F/T sensors of :mod:`wbc.sim.sensors`
            (MuJoCo sensors; they do not change the physics).
        plant: ``"ideal"`` (joints are ideal torque sources: the plant equals the Pinocchio model) or
            ``"realistic"`` (the drives of :func:`wbc.sim.actuators.actuator_model` with its defaults: URDF damping
            and dry friction, rotor armature, torque–speed envelope; replaces ``zero_joint_damping_friction``).
            For other drive settings call :func:`wbc.sim.actuators.apply_actuators` on the ideal model.
        terrain: a :class:`wbc.terrain.Terrain` (or its description, :func:`wbc.terrain.parse_terrain`); None or
            flat: the plane ``z = 0`` alone. Otherwise :func:`add_terrain` builds it (the base plane ``floor`` at
            the terrain's ``floor_z``, one box geom per terrain box, an ``hfield``), every part a ground geom.

    Returns:
        A :class:`MujocoModel` whose state is ``robot.q_ref`` at rest (``mj_forward`` done).

    Raises:
        InvalidInputError: a bad option value (``plant`` not ``"ideal"``/``"realistic"`` included).
        SimulationError: the URDF cannot be compiled or does not match the Pinocchio model (joint names,
            joint types, total mass).
    """
    if not (0.0 < timestep <= MAX_TIMESTEP):
        raise InvalidInputError(f"timestep must be in (0, {MAX_TIMESTEP}] s, got {timestep}")
    if foot_contact not in ("box", "urdf"):
        raise InvalidInputError(f"foot_contact must be 'box' or 'urdf', got {foot_contact!r}")
    if self_collision not in (False, "srdf", "all"):
        raise InvalidInputError(f"self_collision must be False, 'srdf' or 'all', got {self_collision!r}")
    if self_collision == "srdf" and robot.srdf_path is None:
        raise InvalidInputError(f"self_collision='srdf' but robot {robot.name!r} has no SRDF")
    integrators = {"euler": "EULER", "implicitfast": "IMPLICITFAST", "implicit": "IMPLICIT", "rk4": "RK4"}
    if integrator not in integrators:
        raise InvalidInputError(f"integrator must be one of {sorted(integrators)}, got {integrator!r}")
    if cone not in ("elliptic", "pyramidal"):
        raise InvalidInputError(f"cone must be 'elliptic' or 'pyramidal', got {cone!r}")
    if not (np.isfinite(impratio) and impratio >= 1.0):
        raise InvalidInputError(f"impratio must be finite and >= 1, got {impratio!r}")
    if friction_timeconst is None:
        friction_timeconst = 2.0 * timestep
    if not (np.isfinite(friction_timeconst) and (friction_timeconst == 0.0
                                                 or friction_timeconst >= 2.0 * timestep * (1.0 - 1e-12))):
        raise InvalidInputError(f"friction_timeconst must be 0 or >= 2 * timestep = {2.0 * timestep} s, got "
                                f"{friction_timeconst!r}")
    if ground_timeconst is not None and not (
            isinstance(ground_timeconst, (int, float, np.floating)) and not isinstance(ground_timeconst, bool)
            and np.isfinite(ground_timeconst) and ground_timeconst >= 2.0 * timestep * (1.0 - 1e-12)):
        raise InvalidInputError(f"ground_timeconst must be None or a number >= 2 * timestep = {2.0 * timestep} s, got "
                                f"{ground_timeconst!r}")
    if not (floor_friction > 0 and foot_box_thickness > 0):
        raise InvalidInputError("floor_friction and foot_box_thickness must be positive")
    if plant not in PLANTS:
        raise InvalidInputError(f"plant must be one of {PLANTS}, got {plant!r}")

    pmodel = robot.model
    text = _urdf_for_mujoco(robot)
    try:
        spec = mujoco.MjSpec.from_string(text)
    except Exception as exc:  # mujoco raises ValueError with the compiler message
        raise SimulationError(f"MuJoCo cannot load the URDF of {robot.name!r}: {exc}") from exc
    spec.option.timestep = float(timestep)
    spec.option.integrator = getattr(mujoco.mjtIntegrator, f"mjINT_{integrators[integrator]}")
    spec.option.cone = getattr(mujoco.mjtCone, f"mjCONE_{cone.upper()}")
    spec.option.impratio = float(impratio)

    roots = list(spec.worldbody.bodies)
    if len(roots) != 1 or list(roots[0].joints):
        raise SimulationError(f"URDF of {robot.name!r} must have one jointless root link, got {len(roots)}")
    roots[0].add_freejoint(name="root_joint")

    # Joints (matched by name) and actuators, in Pinocchio order.
    joint_names = list(pmodel.names[2:])
    mj_joint_names = {j.name for j in spec.joints if j.type != mujoco.mjtJoint.mjJNT_FREE}
    if set(joint_names) != mj_joint_names:
        raise SimulationError(
            f"joint names differ between Pinocchio and MuJoCo for {robot.name!r}: only in Pinocchio "
            f"{sorted(set(joint_names) - mj_joint_names)}, only in MuJoCo {sorted(mj_joint_names - set(joint_names))}"
        )
    effort = np.array([pmodel.effortLimit[pmodel.joints[i].idx_v] for i in range(2, pmodel.njoints)])
    effort = np.where((effort > 0) & np.isfinite(effort), effort, np.inf)
    for i, name in enumerate(joint_names):
        jmodel = pmodel.joints[i + 2]
        if jmodel.nv != 1:
            raise SimulationError(f"joint {name!r} has {jmodel.nv} DoF; only 1-DoF joints are supported")
        joint = spec.joint(name)
        if zero_joint_damping_friction:
            joint.damping, joint.frictionloss = np.zeros(3), 0.0  # damping: polynomial coefficients
        joint.armature = float(pmodel.armature[jmodel.idx_v])
        limited = bool(np.isfinite(effort[i]))
        joint.actfrclimited = mujoco.mjtLimited.mjLIMITED_TRUE if limited else mujoco.mjtLimited.mjLIMITED_FALSE
        act = spec.add_actuator(name=name, target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        act.set_to_motor()
        act.gear[0] = 1.0
        if limited:
            joint.actfrcrange = [-effort[i], effort[i]]
            act.ctrllimited = act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
            act.ctrlrange = act.forcerange = [-effort[i], effort[i]]
        else:
            act.ctrllimited = act.forcelimited = mujoco.mjtLimited.mjLIMITED_FALSE

    # Collision geometry: feet, bits, floor, self-collision exclusions.
    feet = {side: _foot(robot, getattr(robot, f"{side}_sole")) for side in SIDES}
    foot_body_names = {side: feet[side][1] for side in SIDES}
    self_bits = ROBOT_BIT if self_collision else 0
    for geom in list(spec.geoms):
        if geom.contype == 0 and geom.conaffinity == 0:
            continue  # visual geom
        body = geom.parent.name
        if foot_contact == "box" and any(body in names for names in foot_body_names.values()):
            spec.delete(geom)
            continue
        geom.contype, geom.conaffinity = ROBOT_BIT, ENV_BIT | self_bits
        geom.margin = geom.gap = 0.0
    if foot_contact == "urdf":
        _visual_feet(spec, foot_body_names, ROBOT_BIT, ENV_BIT | self_bits, robot.name)
        _mesh_sole_pads(spec, feet, ROBOT_BIT, ENV_BIT | self_bits, robot.name)
    if foot_contact == "box":
        h = float(foot_box_thickness)
        for side in SIDES:
            body_name, _, placement = feet[side]
            center = placement.translation + placement.rotation @ np.array([0.0, 0.0, 0.5 * h])
            quat = pin.Quaternion(placement.rotation)
            spec.body(body_name).add_geom(
                name=f"{side}_foot_box", type=mujoco.mjtGeom.mjGEOM_BOX, pos=center,
                quat=[quat.w, quat.x, quat.y, quat.z],
                size=[0.5 * robot.sole_length, 0.5 * robot.sole_width, 0.5 * h],
                contype=ROBOT_BIT, conaffinity=ENV_BIT | self_bits, group=3, rgba=[0.9, 0.5, 0.1, 0.5],
            )
    spec.worldbody.add_geom(
        name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0.0, 0.0, 0.05], contype=ENV_BIT,
        conaffinity=ENV_BIT | ROBOT_BIT, friction=[floor_friction, 0.005, 0.0001], priority=1,
        rgba=[0.8, 0.8, 0.8, 1.0],
    )
    ground_names = ["floor"]
    if terrain is not None:
        from wbc.terrain import parse_terrain

        terrain = parse_terrain(terrain)
        ground_names += add_terrain(spec, terrain, floor_friction)
    if ground_timeconst is not None:
        for name in ground_names:
            spec.geom(name).solref = [float(ground_timeconst), 1.0]
    if self_collision == "srdf":
        bodies = {b.name for b in spec.bodies}
        for a, b in _srdf_disabled_pairs(robot.srdf_path):
            if a in bodies and b in bodies:
                spec.add_exclude(bodyname1=a, bodyname2=b)
    if sensors:
        from wbc.sim.sensors import add_sensors

        add_sensors(spec, robot)
    if customize is not None:
        customize(spec)
    if friction_timeconst > 0.0:
        stiff_foot_friction(spec, roots[0].name, foot_body_names, friction_timeconst)

    try:
        model = spec.compile()
    except Exception as exc:
        raise SimulationError(f"MuJoCo cannot compile the model of {robot.name!r}: {exc}") from exc
    sim = _assemble(robot, model, feet, foot_contact, not zero_joint_damping_friction, effort)
    sim.ground_geoms = np.array([model.geom(n).id for n in ground_names], dtype=int)
    sim.terrain = terrain
    if plant == "realistic":
        apply_actuators(sim, actuator_model(robot, plant))
        sim.damping_friction_in_sim = True
        sim.set_state(robot.q_ref, np.zeros(pmodel.nv))
    return sim


def add_terrain(spec: mujoco.MjSpec, terrain, friction: float = 1.0) -> list[str]:
    """Add a terrain's geometry to ``spec`` (world body), with the floor's collision bits, friction and priority.

    The plane ``floor`` (already in the spec) moves to ``z = terrain.floor_z``; each :class:`wbc.terrain.Box`
    becomes a box geom ``terrain_box_<i>`` (same centre, size and rotation); the heightfield becomes an ``hfield``
    asset ``terrain_hf`` and its geom ``terrain_hfield`` (MuJoCo triangulates each cell along the diagonal from
    node (i, j) to (i + 1, j + 1), as :meth:`wbc.terrain.Heightfield.height`; heights stored in float32).

    Args:
        spec: the model being built. terrain: a :class:`wbc.terrain.Terrain`. friction: sliding friction.

    Returns:
        Names of the geoms added (the ground geoms besides ``floor``).
    """
    floor = spec.geom("floor")
    floor.pos = [0.0, 0.0, float(terrain.floor_z)]
    common = dict(contype=ENV_BIT, conaffinity=ENV_BIT | ROBOT_BIT, friction=[friction, 0.005, 0.0001],
                  priority=1)
    names = []
    for i, box in enumerate(terrain.boxes):
        quat = pin.Quaternion(box.rotation)
        name = f"terrain_box_{i}"
        spec.worldbody.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_BOX, pos=box.center.tolist(),
                                quat=[quat.w, quat.x, quat.y, quat.z], size=(0.5 * box.size).tolist(),
                                rgba=[0.6, 0.6, 0.65, 1.0], **common)
        names.append(name)
    hf = terrain.heightfield
    if hf is not None:
        h = hf.heights
        lo, hi = float(h.min()), float(h.max())
        span = max(hi - lo, 1e-6)
        x0, x1, y0, y1 = hf.extent
        asset = spec.add_hfield(name="terrain_hf", nrow=h.shape[0], ncol=h.shape[1],
                                size=[0.5 * (x1 - x0), 0.5 * (y1 - y0), span, 0.05])
        asset.userdata = ((h - lo) / span).astype(np.float32).ravel().tolist()  # row i: y0 + i spacing
        spec.worldbody.add_geom(name="terrain_hfield", type=mujoco.mjtGeom.mjGEOM_HFIELD, hfieldname="terrain_hf",
                                pos=[0.5 * (x0 + x1), 0.5 * (y0 + y1), lo], rgba=[0.55, 0.5, 0.45, 1.0], **common)
        names.append("terrain_hfield")
    return names


def stiff_foot_friction(spec: mujoco.MjSpec, robot_root: str, foot_bodies: dict[str, set[str]],
                        timeconst: float) -> int:
    """Give the friction rows of every foot contact the time constant ``timeconst`` (s), the normal rows unchanged.

    MuJoCo sets ``solreffriction`` on explicit contact pairs only, so each pair (foot geom, geom outside the robot
    that the foot geom collides with by its contype/conaffinity bits) becomes a ``<pair>`` with the parameters
    MuJoCo would give the dynamic contact (``mj_contactParam``: those of the geom of higher priority, otherwise
    condim and friction the larger, solref and solimp mixed by solmix; margin and gap the larger) plus
    ``solreffriction = (timeconst, 1)``, and the dynamic contacts between those bodies are excluded. Unnamed
    geoms of such pairs get a name (``pair_geom_<i>``). Called by :func:`build_mujoco_model` after ``customize``.

    Args:
        spec: the model being built. robot_root: name of the robot's root body (its subtree is the robot).
        foot_bodies: side -> names of the bodies rigidly attached to that sole. timeconst: s (> 0).

    Returns:
        The number of pairs added.
    """
    robot = {b.name for b in spec.body(robot_root).find_all(mujoco.mjtObj.mjOBJ_BODY)} | {robot_root}
    feet = set().union(*foot_bodies.values())
    colliding = [g for g in spec.geoms if g.contype or g.conaffinity]
    foot_geoms = [g for g in colliding if g.parent.name in feet]
    others = [g for g in colliding if g.parent.name not in robot]
    for i, g in enumerate(foot_geoms + others):
        if not g.name:
            g.name = f"pair_geom_{i}"
    excluded, n = set(), 0
    for f in foot_geoms:
        for g in others:
            if not (f.contype & g.conaffinity or g.contype & f.conaffinity):
                continue
            bodies = (f.parent.name, g.parent.name)
            if bodies not in excluded:
                spec.add_exclude(bodyname1=bodies[0], bodyname2=bodies[1])
                excluded.add(bodies)
            condim, friction, solref, solimp = _contact_param(f, g)
            spec.add_pair(geomname1=f.name, geomname2=g.name, condim=condim,
                          friction=[friction[0], friction[0], friction[1], friction[2], friction[2]],
                          solref=solref, solimp=solimp, solreffriction=[float(timeconst), 1.0],
                          margin=max(f.margin, g.margin), gap=max(f.gap, g.gap))
            n += 1
    return n


def _contact_param(g1, g2) -> tuple[int, np.ndarray, np.ndarray, np.ndarray]:
    """(condim, friction (3,), solref (2,), solimp (5,)) of a dynamic contact between two spec geoms, as MuJoCo's
    ``mj_contactParam`` computes them."""
    if g1.priority != g2.priority:
        g = g1 if g1.priority > g2.priority else g2
        return g.condim, np.array(g.friction), np.array(g.solref), np.array(g.solimp)
    m1, m2 = g1.solmix, g2.solmix
    tiny = mujoco.mjMINVAL
    mix = m1 / (m1 + m2) if m1 >= tiny and m2 >= tiny else 0.5 if m1 < tiny and m2 < tiny else float(m2 < tiny)
    r1, r2 = np.array(g1.solref), np.array(g2.solref)
    solref = mix * r1 + (1.0 - mix) * r2 if r1[0] > 0 and r2[0] > 0 else np.minimum(r1, r2)
    solimp = mix * np.array(g1.solimp) + (1.0 - mix) * np.array(g2.solimp)
    return max(g1.condim, g2.condim), np.maximum(g1.friction, g2.friction), solref, solimp


def _assemble(robot, model, feet, foot_contact, keep_df, effort) -> MujocoModel:
    pmodel = robot.model
    mass = float(model.body_subtreemass[1])
    if abs(mass - robot.mass) > 1e-9 * max(1.0, robot.mass):
        raise SimulationError(f"MuJoCo total mass {mass} kg differs from Pinocchio's {robot.mass} kg")
    if model.jnt_type[0] != mujoco.mjtJoint.mjJNT_FREE or model.jnt_bodyid[0] != 1:
        raise SimulationError("the root free joint must be MuJoCo's first joint, on body 1")
    pin_q, mj_qpos, pin_cs, mj_cs, mj_qvel = [], [], [], [], []
    for i in range(2, pmodel.njoints):
        jm, jid = pmodel.joints[i], model.joint(pmodel.names[i]).id
        mj_qvel.append(model.jnt_dofadr[jid])
        if jm.nq == 1:
            pin_q.append(jm.idx_q)
            mj_qpos.append(model.jnt_qposadr[jid])
        elif jm.nq == 2 and model.jnt_type[jid] == mujoco.mjtJoint.mjJNT_HINGE:
            pin_cs.append([jm.idx_q, jm.idx_q + 1])
            mj_cs.append(model.jnt_qposadr[jid])
        else:
            raise SimulationError(f"joint {pmodel.names[i]!r} ({jm.shortname()}) has no MuJoCo equivalent")
    smap = StateMap(
        nq=pmodel.nq, nv=pmodel.nv, nq_mj=7 + len(pin_q) + len(pin_cs), pin_q=np.array(pin_q, dtype=int),
        mj_qpos=np.array(mj_qpos, dtype=int), pin_q_cs=np.array(pin_cs, dtype=int).reshape(-1, 2),
        mj_qpos_cs=np.array(mj_cs, dtype=int), mj_qvel=np.array(mj_qvel, dtype=int),
    )

    def body_id(name: str) -> int:
        return mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, name)

    foot_bodies = {s: np.array(sorted(body_id(n) for n in feet[s][1]), dtype=int) for s in SIDES}
    if foot_contact == "box":
        foot_geoms = {s: np.array([model.geom(f"{s}_foot_box").id]) for s in SIDES}
    else:
        colliding = (model.geom_contype != 0) | (model.geom_conaffinity != 0)
        foot_geoms = {
            s: np.flatnonzero(colliding & np.isin(model.geom_bodyid, foot_bodies[s])) for s in SIDES
        }
    sole_placements = {s: (body_id(feet[s][0]), feet[s][2]) for s in SIDES}
    v_idx = [pmodel.joints[i].idx_v for i in range(2, pmodel.njoints)]
    mm = MujocoModel(
        robot=robot, model=model, data=mujoco.MjData(model), state_map=smap,
        actuator_ids=np.array([model.actuator(n).id for n in pmodel.names[2:]], dtype=int),
        effort_limit=effort, joint_damping=np.array(pmodel.damping[v_idx]),
        joint_friction=np.array(pmodel.friction[v_idx]), damping_friction_in_sim=keep_df,
        floor_geom=model.geom("floor").id, foot_geoms=foot_geoms, foot_bodies=foot_bodies,
        sole_placements=sole_placements,
    )
    mm.set_state(robot.q_ref, np.zeros(pmodel.nv))
    return mm


def _visual_feet(spec: mujoco.MjSpec, foot_body_names: dict[str, set[str]], contype: int, conaffinity: int,
                 name: str) -> None:
    """Feet with ``foot_contact="urdf"`` whose bodies carry no collision geom touch the ground through their
    visual geometry (MuJoCo collides a mesh by its convex hull): its geoms get the robot's collision bits, with a
    warning. A foot without any geometry raises."""
    for side, bodies in foot_body_names.items():
        geoms = [g for g in spec.geoms if g.parent.name in bodies]
        if any(g.contype or g.conaffinity for g in geoms):
            continue
        if not geoms:
            raise SimulationError(f"{name}: the {side} foot (bodies {sorted(bodies)}) has no collision or visual "
                                  f"geometry to touch the ground with; use [mujoco] foot = \"box\" (a box of the "
                                  f"sole rectangle)")
        for g in geoms:
            g.contype, g.conaffinity = contype, conaffinity
            g.margin = g.gap = 0.0
        warnings.warn(f"{name}: the {side} foot has no collision geometry; its {len(geoms)} visual geoms (convex "
                      f"hulls) are its ground contact", stacklevel=3)


def _mesh_sole_pads(spec: mujoco.MjSpec, feet: dict, contype: int, conaffinity: int, name: str) -> None:
    """Point contacts on the flat bottom of mesh feet (``foot_contact="urdf"``): one sphere of radius
    :data:`SOLE_PAD_RADIUS` on each corner of the foot's contact patch, its lowest point on the corner.

    MuJoCo collides a mesh with a plane at its support point in −n (the deepest vertex) plus at most three
    vertices connected to it (``mjc_PlaneConvex``, ``maxplanemesh = 3`` in ``engine_collision_convex.c``). A mesh
    foot whose bottom is flat stands on three or four of its coplanar vertices, chosen anew each step by which one
    is deepest: a roll or pitch of less than 0.1° moves the whole support from one edge of the sole to the other.
    Under load the foot rocks between these vertex sets at tens of Hz, where a real flat sole would shift its
    pressure continuously. The patch is the foot's own geometry: the vertices of its colliding mesh geoms within
    :data:`wbc.robot_inspect.FLAT_BAND` (as for the sole rectangle of ``wbc robot init``) of the lowest along the
    sole normal; the pads stand on the corners of that patch's
    convex hull (at each corner's own height, so a patch that is not flat stays so). The mesh keeps colliding
    (heel, toe and edges when the foot tilts). Feet without mesh geoms (boxes, spheres, cylinders: MuJoCo gives
    them their own face or point contacts) get none. The pads are massless (``inertiafromgeom="false"``) geoms of
    group 3 named ``{side}_sole_pad_{i}`` on the link moved by the ankle joint."""
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)  # the foot bodies are rigid: their relative poses hold at any qpos
    colliding = (model.geom_contype != 0) | (model.geom_conaffinity != 0)
    for side, (link, bodies, sole_in_link) in feet.items():
        lid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, link)
        world_link = pin.SE3(np.array(data.xmat[lid]).reshape(3, 3), np.array(data.xpos[lid]))
        world_sole = world_link * sole_in_link
        pts = []
        for g in np.flatnonzero(colliding & (model.geom_type == mujoco.mjtGeom.mjGEOM_MESH)):
            if model.body(model.geom_bodyid[g]).name not in bodies:
                continue
            mid = model.geom_dataid[g]
            verts = np.array(model.mesh_vert[model.mesh_vertadr[mid]:model.mesh_vertadr[mid] + model.mesh_vertnum[mid]])
            world = verts @ np.array(data.geom_xmat[g]).reshape(3, 3).T + np.array(data.geom_xpos[g])
            pts.append((world - world_sole.translation) @ world_sole.rotation)  # in the sole frame
        if not pts:
            continue
        p = np.vstack(pts)
        patch = p[p[:, 2] <= p[:, 2].min() + FLAT_BAND]
        try:
            corners = convex_hull(patch[:, :2])
        except InvalidInputError:
            continue  # fewer than three points, or a line: no flat patch to stand on
        up = sole_in_link.rotation[:, 2]  # sole normal in the link frame
        body = spec.body(link)
        for i, c in enumerate(corners):
            k = int(np.argmin(np.linalg.norm(patch[:, :2] - c, axis=1)))
            at = sole_in_link.act(patch[k]) + SOLE_PAD_RADIUS * up
            body.add_geom(name=f"{side}_sole_pad_{i}", type=mujoco.mjtGeom.mjGEOM_SPHERE, pos=at,
                          size=[SOLE_PAD_RADIUS, 0.0, 0.0], contype=contype, conaffinity=conaffinity, group=3,
                          margin=0.0, gap=0.0, rgba=[0.9, 0.5, 0.1, 0.5])


def _foot(robot: Robot, sole: str) -> tuple[str, set[str], pin.SE3]:
    """(MuJoCo body carrying the sole's joint, names of all bodies rigidly attached to it, sole in that body)."""
    pmodel = robot.model
    frame = pmodel.frames[robot.frame_id(sole)]
    joint = frame.parentJoint
    bodies = [f for f in pmodel.frames if f.type == pin.FrameType.BODY and f.parentJoint == joint]
    # The link moved by the joint: its BODY frame has the joint frame placement closest to identity (the child
    # link of the joint); fixed links hang below it.
    link = next((f for f in bodies if f.parentFrame == _joint_frame_id(pmodel, joint)), None)
    if link is None:
        raise SimulationError(f"cannot find the link moved by joint {pmodel.names[joint]!r} (sole {sole!r})")
    return link.name, {f.name for f in bodies}, link.placement.actInv(frame.placement)


def _joint_frame_id(pmodel: pin.Model, joint: int) -> int:
    return next(i for i, f in enumerate(pmodel.frames) if f.type == pin.FrameType.JOINT and f.parentJoint == joint)


def _urdf_for_mujoco(robot: Robot) -> str:
    """URDF text with absolute mesh paths and MuJoCo compiler options (see the module docstring)."""
    urdf = Path(robot.urdf_path)
    text = robot.urdf_xml if getattr(robot, "urdf_xml", None) is not None else urdf.read_text()
    dirs = [Path(d) for d in robot.package_dirs]
    mode = robot.spec.mujoco.meshes if getattr(robot, "spec", None) is not None else "convert"
    if mode == "collision":  # visuals MuJoCo cannot read are dropped: the collision geometry is shown instead
        def drop(match: re.Match) -> str:
            names = re.findall(r"""filename\s*=\s*["']([^"']+)["']""", match.group(0))
            if any(Path(n).suffix.lower() not in MUJOCO_MESH_SUFFIXES for n in names):
                dropped.append(names[0])
                return ""
            return match.group(0)

        dropped: list[str] = []
        text = re.sub(r"<visual\b.*?</visual>", drop, text, flags=re.S)
        if dropped:
            warnings.warn(f"{robot.name}: {len(dropped)} visual meshes MuJoCo cannot read were dropped (the "
                          f"collision geometry is shown), e.g. {dropped[0]}", stacklevel=3)

    def resolve(match: re.Match) -> str:
        ref = match.group(2)
        if ref.startswith("package://"):
            rel = ref[len("package://"):].lstrip("/")  # package:///NAME/... (an empty authority) as package://NAME/...
            candidates = [d / rel for d in dirs]
        elif ref.startswith("file://"):
            candidates = [Path(ref[len("file://"):])]
        else:
            candidates = [urdf.parent / ref]
        for c in candidates:
            if c.is_file():
                return f"{match.group(1)}{mujoco_readable(c.resolve())}{match.group(3)}"
        raise SimulationError(f"mesh {ref!r} of {urdf} not found (searched {[str(c) for c in candidates]})")

    text = re.sub(r"""(<mesh\b[^>]*?\bfilename\s*=\s*["'])([^"']+)(["'])""", resolve, text)
    text = re.sub(r"<mujoco\b.*?</mujoco>|<mujoco\b[^>]*/>", "", text, flags=re.S)
    compiler = (
        '<mujoco><compiler fusestatic="false" discardvisual="false" strippath="false" '
        'inertiafromgeom="false" balanceinertia="false" angle="radian"/></mujoco>'
    )
    text, n = re.subn(r"(<robot\b[^>]*>)", lambda m: m.group(1) + compiler, text, count=1)
    if n != 1:
        raise SimulationError(f"{urdf} has no <robot> element")
    return text


def _srdf_disabled_pairs(srdf: Path) -> list[tuple[str, str]]:
    root = ET.parse(srdf).getroot()
    return [(e.get("link1"), e.get("link2")) for e in root.iter("disable_collisions")]
