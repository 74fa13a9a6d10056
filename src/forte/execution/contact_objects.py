"""The objects of a contact-rich task in MuJoCo (issue 25, item 4), and what a run measures of them.

:class:`ContactRig` adds the task's object to the model (:func:`forte.execution.model.build_sim_model`'s
``decorate``), applies the partner's force at every step and measures the force the hand exerts:

- **push-box**: a box (free joint, the task's mass and size, uniform density) on the floor ahead of
  the hand, its front face against a pusher plate on the hand (a massless 0.02 x 0.2 x 0.16 m box
  at the end effector, its face normal the push direction ``d``). The only contacts are plate-box
  and box-floor (contact bit :data:`OBJECT`; the robot's own geoms never touch the box); the
  box-floor pair is explicit with the task's friction ``mu`` (sliding; torsional 0.005, rolling
  1e-4). Measured: the plate's contact force on the box along ``d``. The run fails (reason
  ``object``) when the box ends more than :data:`TRAVEL_TOLERANCE` from the planned travel or turns
  more than :data:`YAW_TOLERANCE`.
- **drawer**: a body on a slide joint along ``d`` through the hand's start position, with the task's
  mass, stiffness (rest position ``rest``), damping and friction loss; its handle (a site at the
  body's origin) is held at the end effector by a ``connect`` equality (the grasp, position only).
  Measured: the constraint force the hand exerts on the handle along ``d``; fails (``object``) when
  the drawer's opening ends more than :data:`TRAVEL_TOLERANCE` from the plan's.
- **carry**: the board is the plan's payload (carried at its centre of mass, :mod:`forte.execution.bodies`);
  the partner's force ``f_p(t)`` (:meth:`forte.force.contact.Carry.partner_force`) is applied on it at
  their grip, ``p_ee + R_ee e``, at every step, so the partner lets go in the simulation as in the plan.

``d`` is the direction of the plan's largest force sample (the push and drawer models act along it).
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from forte.execution.bodies import _rot_to_quat
from forte.execution.contact import OBJECT
from forte.force.contact import Carry, Contact, Drawer, PushBox
from forte.validation import FloatArray

#: Half sizes (m) of the pusher plate: thickness along ``d``, width, height.
PLATE_HALF = (0.01, 0.1, 0.08)
#: Largest error (m) of the object's final travel along ``d`` against the plan's.
TRAVEL_TOLERANCE = 0.05
#: Largest yaw (rad) of the pushed box at the end.
YAW_TOLERANCE = 0.35


def _frame(d: FloatArray) -> FloatArray:
    """A rotation with x along ``d`` and y horizontal (z up for a horizontal ``d``)."""
    x = d / np.linalg.norm(d)
    y = np.cross([0.0, 0.0, 1.0], x)
    if np.linalg.norm(y) < 1e-6:
        y = np.array([0.0, 1.0, 0.0])
    y = y / np.linalg.norm(y)
    return np.column_stack([x, y, np.cross(x, y)])


class ContactRig:
    """The object of ``contact`` for a plan starting at the end-effector pose ``T0`` and moving
    along ``d`` for ``travel`` m (module docstring)."""

    def __init__(self, contact: Contact, T0: FloatArray, d: FloatArray, travel: float, gravity: float) -> None:
        self.contact, self.T0, self.gravity = contact, np.asarray(T0, dtype=float), float(gravity)
        self.d = np.asarray(d, dtype=float) / max(float(np.linalg.norm(d)), 1e-12)
        self.travel = float(travel)
        self.sim: Any = None
        self.forces: list[tuple[float, float]] = []

    # -- building ---------------------------------------------------------------------------
    def decorate(self, spec: mujoco.MjSpec) -> None:
        """Add the object to ``spec`` (before compiling)."""
        if isinstance(self.contact, PushBox):
            self._add_box(spec, self.contact)
        elif isinstance(self.contact, Drawer):
            self._add_drawer(spec, self.contact)

    def _ee_link(self, spec: mujoco.MjSpec) -> tuple[Any, FloatArray, FloatArray]:
        site = spec.site("ee")
        R = np.zeros(9)
        mujoco.mju_quat2Mat(R, np.asarray(site.quat, dtype=float))
        return site.parent, np.asarray(site.pos, dtype=float), R.reshape(3, 3)

    def _add_box(self, spec: mujoco.MjSpec, box: PushBox) -> None:
        link, p_site, R_site = self._ee_link(spec)
        R_w = _frame(self.d)
        R_local = self.T0[:3, :3].T @ R_w  # the plate's frame in the end-effector frame
        link.add_geom(name="pusher", type=mujoco.mjtGeom.mjGEOM_BOX, size=list(PLATE_HALF),
                      pos=(p_site + R_site @ (R_local @ np.array([PLATE_HALF[0], 0.0, 0.0]))).tolist(),
                      quat=_rot_to_quat(R_site @ R_local).tolist(), contype=OBJECT, conaffinity=0,
                      mass=0.0, density=0.0, rgba=[0.2, 0.6, 0.9, 1.0], friction=[0.5, 0.005, 0.0001])
        length, width, height = box.size
        centre = self.T0[:3, 3] + self.d * (2 * PLATE_HALF[0] + length / 2 + 1e-3)
        centre[2] = height / 2
        body = spec.worldbody.add_body(name="object", pos=centre.tolist(), quat=_rot_to_quat(R_w).tolist())
        body.add_freejoint(name="object")
        body.explicitinertial = True  # ipos set ourselves: MjSpec defaulted it to the body's pos
        body.ipos, body.iquat = [0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]
        body.mass = box.mass
        body.inertia = [box.mass / 12 * (b**2 + c**2) for b, c in
                        ((width, height), (length, height), (length, width))]
        body.add_geom(name="object", type=mujoco.mjtGeom.mjGEOM_BOX, size=[length / 2, width / 2, height / 2],
                      contype=OBJECT, conaffinity=OBJECT, mass=0.0, density=0.0, rgba=[0.7, 0.5, 0.3, 1.0],
                      friction=[0.5, 0.005, 0.0001])
        spec.add_pair(geomname1="object", geomname2="floor", condim=3,
                      friction=[box.friction, box.friction, 0.005, 1e-4, 1e-4])

    def _add_drawer(self, spec: mujoco.MjSpec, drawer: Drawer) -> None:
        R_w = _frame(self.d)
        body = spec.worldbody.add_body(name="object", pos=self.T0[:3, 3].tolist(), quat=_rot_to_quat(R_w).tolist())
        body.add_joint(name="object", type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[1.0, 0.0, 0.0],
                       stiffness=drawer.stiffness, springref=drawer.rest, damping=drawer.damping,
                       frictionloss=drawer.friction)
        body.explicitinertial = True
        body.ipos, body.iquat = [0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]
        body.mass = drawer.mass
        body.inertia = [0.01, 0.01, 0.01]
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.02, 0.15, 0.02], contype=0, conaffinity=0,
                      mass=0.0, density=0.0, rgba=[0.7, 0.5, 0.3, 1.0])
        body.add_site(name="handle", size=[0.01, 0.0, 0.0])
        spec.add_equality(name="grasp", type=mujoco.mjtEq.mjEQ_CONNECT, objtype=mujoco.mjtObj.mjOBJ_SITE,
                          name1="handle", name2="ee")

    # -- running ----------------------------------------------------------------------------
    def bind(self, sim: Any) -> None:
        """Look up the object in the compiled model of ``sim``."""
        self.sim = sim
        m = sim.model
        self.body = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "object")
        self.joint = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "object")
        self.plate = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "pusher")
        self.box = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "object")
        self.grasp = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_EQUALITY, "grasp")
        self.start = None if self.body < 0 else sim.data.xpos[self.body].copy()

    def apply(self, t: float) -> None:
        """Before a step at time ``t``: the partner's force on the carried board."""
        if not isinstance(self.contact, Carry):
            return
        sim = self.sim
        T = sim.ee_pose()
        point = T[:3, 3] + T[:3, :3] @ np.asarray(self.contact.partner, dtype=float)
        sim.data.qfrc_applied[:] = 0.0
        f_p = self.contact.partner_force([t], self.gravity)[0]
        mujoco.mj_applyFT(sim.model, sim.data, f_p, np.zeros(3), point, sim.payload_body, sim.data.qfrc_applied)

    def measure(self, t: float) -> None:
        """After a step: the force the hand exerts on the object along ``d`` (N)."""
        if isinstance(self.contact, PushBox):
            self.forces.append((t, float(self.hand_force() @ self.d)))
        elif isinstance(self.contact, Drawer):
            self.forces.append((t, float(self.hand_force() @ self.d)))

    def hand_force(self) -> FloatArray:
        """The force (world, N) the hand exerts on the object: the plate's contacts on the box, or
        the grasp constraint's force on the handle."""
        m, d = self.sim.model, self.sim.data
        total = np.zeros(3)
        if isinstance(self.contact, PushBox):
            local = np.zeros(6)
            for i in range(d.ncon):
                c = d.contact[i]
                if {int(c.geom1), int(c.geom2)} != {self.plate, self.box}:
                    continue
                mujoco.mj_contactForce(m, d, i, local)
                f = c.frame.reshape(3, 3).T @ local[:3]  # on geom2, from geom1
                total += f if int(c.geom2) == self.box else -f
            return total
        rows = np.flatnonzero((d.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY) & (d.efc_id == self.grasp))
        return d.efc_force[rows].copy() if rows.size == 3 else total

    def opening(self) -> float:
        """How far (m) the object moved along ``d`` since the start."""
        return float((self.sim.data.xpos[self.body] - self.start) @ self.d)

    def outcome(self) -> tuple[dict[str, Any], str | None]:
        """What the run records about the object, and why it failed (``None``: it did not)."""
        facts: dict[str, Any] = {"kind": self.contact.kind}
        if isinstance(self.contact, Carry):
            return facts, None
        moved = self.opening()
        facts |= {"planned_travel_m": self.travel, "travel_m": moved}
        if self.forces:
            f = np.array([v for _, v in self.forces])
            facts |= {"peak_hand_force_N": float(np.max(f)), "mean_hand_force_N": float(np.mean(f))}
        if abs(moved - self.travel) > TRAVEL_TOLERANCE:
            return facts, f"the {self.contact.kind} moved {moved:.3f} m of the planned {self.travel:.3f} m"
        if isinstance(self.contact, PushBox):
            R = self.sim.data.xmat[self.body].reshape(3, 3)
            yaw = float(np.arccos(np.clip(R[:, 0] @ _frame(self.d)[:, 0], -1.0, 1.0)))
            facts["yaw_rad"] = yaw
            if yaw > YAW_TOLERANCE:
                return facts, f"the box turned {yaw:.2f} rad"
        return facts, None


def rig_for(contact: Contact | None, robot: Any, q: FloatArray, force: Any) -> ContactRig | None:
    """The rig of a plan's contact (``None`` without one): its start pose, direction and travel."""
    if contact is None:
        return None
    T0, T1 = robot.ee_pose(q[0]), robot.ee_pose(q[-1])
    f = np.asarray(force.f, dtype=float) if force is not None else np.zeros((1, 3))
    k = int(np.argmax(np.linalg.norm(f, axis=1)))
    d = f[k] if np.linalg.norm(f[k]) > 1e-9 else T1[:3, 3] - T0[:3, 3]
    d = d / max(float(np.linalg.norm(d)), 1e-12)
    return ContactRig(contact, T0, d, float((T1[:3, 3] - T0[:3, 3]) @ d), robot.gravity)
