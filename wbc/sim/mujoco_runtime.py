"""Run-time side of the MuJoCo model: state in Pinocchio conventions, torques, contacts, external forces.

Build instances with :func:`wbc.sim.mujoco_model.build_mujoco_model`; the conventions are documented in
:mod:`wbc.sim.mujoco_model`.
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass, field

import mujoco
import numpy as np
import pinocchio as pin

from wbc.exceptions import UnknownFrameError
from wbc.robot import Robot
from wbc.geometry import FLOAT64
from wbc.sim.conventions import StateMap, check_vector

__all__ = ["MujocoModel"]


@dataclass
class MujocoModel:
    """A MuJoCo model of a :class:`Robot` plus the maps to and from Pinocchio conventions.

    Methods taking ``data`` default to :attr:`data`; any ``mujoco.MjData(model)`` works (parallel rollouts).
    The robot's state is the first ``state_map.nq_mj`` qpos / ``nv`` qvel entries (bodies added through
    ``customize`` come after it). Contact helpers read ``data.contact``: call them after ``mj_forward`` or
    ``mj_step``; only contacts with the ``floor`` geom count as ground contacts.

    Attributes:
        robot: the robot (its Pinocchio model is the reference for every convention).
        model, data: MuJoCo model and data.
        state_map: index maps and conversions (:class:`~wbc.sim.conventions.StateMap`).
        actuator_ids: (nv - 6,) MuJoCo actuator of Pinocchio's ``v[6 + i]`` (``arange``: built in that order).
        effort_limit: (nv - 6,) torque limits (N·m or N), Pinocchio order; inf when the URDF gives none.
        joint_damping, joint_friction: (nv - 6,) URDF viscous damping (N·m·s/rad) and dry friction (N·m),
            Pinocchio order; applied by MuJoCo only when ``damping_friction_in_sim``.
        floor_geom: geom id of the ground plane.
        ground_geoms: ids of every ground geom (the plane and the terrain's boxes and heightfield,
            :func:`wbc.sim.mujoco_model.add_terrain`); None: the plane alone.
        terrain: the :class:`wbc.terrain.Terrain` built into the model, or None (flat).
        foot_geoms: side ("left"/"right") -> geom ids that make the foot's ground contact.
        foot_bodies: side -> ids of the bodies rigidly attached to the sole frame.
        sole_placements: side -> (body id, sole frame placement in that body's frame).
        drive: the drives' torque–speed envelope applied by :meth:`set_torques`
            (:class:`~wbc.sim.actuators.ActuatorModel`, installed by :func:`~wbc.sim.actuators.apply_actuators`);
            None: ideal torque sources (clamped to the effort limits by MuJoCo).
    """

    robot: Robot
    model: mujoco.MjModel
    data: mujoco.MjData
    state_map: StateMap
    actuator_ids: np.ndarray
    effort_limit: np.ndarray
    joint_damping: np.ndarray
    joint_friction: np.ndarray
    damping_friction_in_sim: bool
    floor_geom: int
    foot_geoms: dict[str, np.ndarray]
    foot_bodies: dict[str, np.ndarray]
    sole_placements: dict[str, tuple[int, pin.SE3]]
    drive: object | None = None
    ground_geoms: np.ndarray | None = None
    terrain: object | None = None
    #: (MjData, its qvel, its ctrl, (nv - 6,)): :meth:`set_torques`' views of the fixed buffers of the last MjData
    #: it wrote (one binding call each, not per tick)
    _torque_views: tuple | None = field(default=None, init=False, repr=False, compare=False)

    @property
    def timestep(self) -> float:
        """Integration step (s)."""
        return float(self.model.opt.timestep)

    @property
    def total_mass(self) -> float:
        """Total robot mass (kg) as MuJoCo sees it (equals ``robot.mass``)."""
        return float(self.model.body_subtreemass[1])

    @property
    def root_body(self) -> int:
        """Body id of the floating base (the URDF root link)."""
        return 1

    # -- state -----------------------------------------------------------------------------------------------
    def set_state(self, q, v=None, *, data: mujoco.MjData | None = None, forward: bool = True) -> None:
        """Write a Pinocchio state into MuJoCo.

        Args:
            q: (nq,) Pinocchio configuration (base quaternion x, y, z, w).
            v: (nv,) Pinocchio velocity (base twist in the base frame); zeros when None.
            forward: run ``mj_forward`` so positions, contacts and forces are up to date.

        Raises:
            InvalidInputError: wrong shapes, NaN/inf, or a non-unit base quaternion.
        """
        d = self.data if data is None else data
        sm = self.state_map
        qpos = sm.q_to_mj(q)
        qvel = np.zeros(sm.nv) if v is None else sm.v_to_mj(q, v)
        d.qpos[: sm.nq_mj] = qpos
        d.qvel[: sm.nv] = qvel
        if forward:
            mujoco.mj_forward(self.model, d)

    def get_state(self, data: mujoco.MjData | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Current state in Pinocchio conventions: ``(q (nq,), v (nv,))``."""
        d = self.data if data is None else data
        sm = self.state_map
        return sm.state_from_mj(d.qpos[: sm.nq_mj], d.qvel[: sm.nv])

    def get_acceleration(self, data: mujoco.MjData | None = None) -> np.ndarray:
        """(nv,) Pinocchio acceleration ``dv/dt`` from ``data.qacc`` (valid after ``mj_forward``/``mj_step``)."""
        d = self.data if data is None else data
        q, v = self.get_state(d)
        return self.state_map.a_from_mj(q, v, d.qacc[: self.state_map.nv])

    def set_torques(self, tau, data: mujoco.MjData | None = None) -> None:
        """Set the joint torques (N·m), ``(nv - 6,)`` in Pinocchio's actuated-joint order (``v[6:]``).

        MuJoCo clamps them to ``±effort_limit``; with a :attr:`drive`, its torque–speed envelope at the current
        joint speeds limits them first. They stay applied until changed.

        Raises:
            InvalidInputError: wrong shape or NaN/inf.
        """
        d = self.data if data is None else data
        drive = self.drive
        if drive is not None and type(tau) is np.ndarray and tau.dtype == FLOAT64 \
                and hasattr(drive, "write_available_torque"):
            views = self._torque_views
            if views is None or views[0] is not d:
                views = self._torque_views = (d, d.qvel, d.ctrl, (self.state_map.nv - 6,))
            if tau.shape == views[3] and drive.write_available_torque(tau, views[1], self.state_map.mj_qvel, views[2],
                                                                      self.actuator_ids):
                return
        tau = check_vector(tau, self.state_map.nv - 6, "tau")  # (the checked path: raises on bad input)
        if self.drive is not None:
            tau = self.drive.available_torque(tau, d.qvel[self.state_map.mj_qvel])
        d.ctrl[self.actuator_ids] = tau

    def step(self, n: int = 1, data: mujoco.MjData | None = None) -> None:
        """Advance ``n`` steps of :attr:`timestep` with the current torques and external forces."""
        d = self.data if data is None else data
        for _ in range(int(n)):
            mujoco.mj_step(self.model, d)

    # -- names -----------------------------------------------------------------------------------------------
    def body_id(self, name: str) -> int:
        """MuJoCo body id of the link ``name``.

        Raises:
            UnknownFrameError: no such body; the message lists close names.
        """
        bid = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, str(name))
        if bid < 0:
            names = [self.model.body(i).name for i in range(1, self.model.nbody)]
            close = difflib.get_close_matches(str(name), names, n=5, cutoff=0.4)
            raise UnknownFrameError(f"MuJoCo model has no body {name!r}; close matches: {close or names[:10]}")
        return bid

    def body_name(self, body_id: int) -> str:
        """Name of the MuJoCo body ``body_id`` (the URDF link name)."""
        return self.model.body(int(body_id)).name

    # -- contacts --------------------------------------------------------------------------------------------
    def _ground_contacts(self, d: mujoco.MjData):
        """Yield (contact index, robot geom id, sign) for contacts with the floor; sign makes forces act on the
        robot geom."""
        con = d.contact
        ground = (self.floor_geom,) if self.ground_geoms is None else set(self.ground_geoms.tolist())
        for i in range(d.ncon):
            g1, g2 = int(con.geom1[i]), int(con.geom2[i])
            if g1 in ground:
                yield i, g2, 1.0
            elif g2 in ground:
                yield i, g1, -1.0

    def non_foot_ground_contacts(self, data: mujoco.MjData | None = None) -> list[str]:
        """Sorted names of the bodies touching the floor through a geom that is not a foot contact geom
        (a fall when non-empty). Valid after ``mj_forward``/``mj_step``."""
        d = self.data if data is None else data
        feet = np.concatenate(list(self.foot_geoms.values()))
        names = {self.body_name(self.model.geom_bodyid[g]) for _, g, _ in self._ground_contacts(d) if g not in feet}
        return sorted(names)

    def self_contacts(self, data: mujoco.MjData | None = None) -> list[tuple[str, str]]:
        """(body1, body2) name pairs of robot–robot contacts (always empty unless built with self-collision)."""
        d = self.data if data is None else data
        con, out = d.contact, []
        for i in range(d.ncon):
            b1, b2 = (int(self.model.geom_bodyid[g]) for g in (con.geom1[i], con.geom2[i]))
            if self.model.body_rootid[b1] == self.model.body_rootid[b2] == self.root_body:
                out.append((self.body_name(b1), self.body_name(b2)))
        return out

    def foot_contact_points(self, data: mujoco.MjData | None = None) -> dict[str, np.ndarray]:
        """side -> (k, 3) world positions (m) of the foot–floor contact points."""
        d = self.data if data is None else data
        pts = {s: [] for s in self.foot_geoms}
        for i, g, _ in self._ground_contacts(d):
            side = self._side_of(g)
            if side is not None:
                pts[side].append(np.array(d.contact.pos[i]))
        return {s: np.array(p).reshape(-1, 3) for s, p in pts.items()}

    def foot_contact_wrenches(self, data: mujoco.MjData | None = None) -> dict[str, np.ndarray]:
        """side -> (6,) ground reaction on the foot: ``[force (N), moment (N·m) about the sole frame origin]``,
        both in the world frame, summed over the foot's contacts (``mj_contactForce``). Zeros without contact."""
        d = self.data if data is None else data
        out = {s: np.zeros(6) for s in self.foot_geoms}
        origins = {s: self.sole_pose(s, d).translation for s in self.foot_geoms}
        local = np.zeros(6)
        for i, g, sign in self._ground_contacts(d):
            side = self._side_of(g)
            if side is None:
                continue
            mujoco.mj_contactForce(self.model, d, i, local)
            frame = np.asarray(d.contact.frame[i]).reshape(3, 3)  # rows: normal (geom1 -> geom2), tangents
            force = sign * frame.T @ local[0:3]
            out[side][0:3] += force
            out[side][3:6] += np.cross(d.contact.pos[i] - origins[side], force) + sign * frame.T @ local[3:6]
        return out

    def foot_contact_forces(self, data: mujoco.MjData | None = None) -> dict[str, np.ndarray]:
        """side -> (3,) world-frame ground reaction force (N) on the foot."""
        return {s: w[0:3].copy() for s, w in self.foot_contact_wrenches(data).items()}

    def sole_pose(self, side: str, data: mujoco.MjData | None = None) -> pin.SE3:
        """World placement of the sole frame of ``side`` from MuJoCo's body pose (after kinematics)."""
        d = self.data if data is None else data
        bid, placement = self.sole_placements[side]
        body = pin.SE3(np.array(d.xmat[bid]).reshape(3, 3), np.array(d.xpos[bid]))
        return body * placement

    def _side_of(self, geom: int) -> str | None:
        for side, geoms in self.foot_geoms.items():
            if geom in geoms:
                return side
        return None

    # -- external forces -------------------------------------------------------------------------------------
    def apply_external_force(
        self, body: str, force, point=None, *, data: mujoco.MjData | None = None
    ) -> None:
        """Apply a world-frame force (N) on ``body`` at a world point (default: the body frame origin).

        ``xfrc_applied`` acts at the body's centre of mass ``xipos``, so the torque ``(point - xipos) × force``
        is written with it; positions are refreshed with ``mj_kinematics`` first (after ``mj_step`` they lag one
        step). Replaces any force already set on that body; it persists until :meth:`clear_external_forces`.

        Raises:
            UnknownFrameError: unknown body. InvalidInputError: ``force``/``point`` not finite (3,) vectors.
        """
        d = self.data if data is None else data
        bid = self.body_id(body)
        f = check_vector(force, 3, "force")
        mujoco.mj_kinematics(self.model, d)
        p = np.array(d.xpos[bid]) if point is None else check_vector(point, 3, "point")
        d.xfrc_applied[bid, 0:3] = f
        d.xfrc_applied[bid, 3:6] = np.cross(p - d.xipos[bid], f)

    def clear_external_forces(self, data: mujoco.MjData | None = None) -> None:
        """Remove every force applied with :meth:`apply_external_force`."""
        (self.data if data is None else data).xfrc_applied[:] = 0.0
