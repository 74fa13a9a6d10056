"""A base on the floor (issue 39): a free body that rests on wheels and casters, can tip and slip.

``forte simulate --base-model floor`` builds the base as a MuJoCo body with a **free joint**
instead of the slide x / slide y / yaw hinge of ``--base-model kinematic``
(:mod:`forte.execution.model`). Its mass and centre of mass are the verdict's
(:class:`~forte.model.base_support.BaseSupport` of the robot, or forte's base box with the
simulator's 60 kg when the robot states none, :func:`~forte.model.base_support.box_support`), so
the tip-over requirement and the simulation weigh the same robot. Its rotational inertia (which
the ZMP model, a point mass, leaves out) is a solid box over the footprint's bounding box, twice
the centre of mass high. The base frame's origin is on the floor, as the planner's.

It stands on a ground plane (``z = 0``, its own contact bit :data:`~forte.execution.contact.SUPPORT`:
only the support geoms touch it) through spheres whose contact points are the support polygon:

- **differential** (``robot.base == "differential"``): two driven wheels on hinges about the base's
  y axis at ``x = 0`` (the point whose lateral velocity the planner keeps at zero), on the
  polygon's left and right edges, each a sphere of radius :data:`WHEEL_RADIUS` with friction
  :data:`WHEEL_FRICTION` (rubber, MuJoCo Menagerie's Stretch: 0.8), driven by velocity actuators
  ``v_wheel_left/right`` (gain :data:`WHEEL_KV`); a passive, frictionless caster sphere
  (``condim 1``, as Stretch's; softer, :data:`CASTER_SOLREF`, as a suspension) at every polygon
  vertex that no wheel occupies. Friction cones are elliptic (as Stretch's). Nothing else
  moves the base: there is no lateral actuator.
- **holonomic**: a frictionless sphere at every polygon vertex, and the planar motion commanded
  by three motors on a site at the base origin on the floor (forces along the base's x and y,
  a torque about its z; :class:`~forte.execution.base_drive.HolonomicDrive`). *Idealised:* omni
  or mecanum wheels push the base along the floor with no friction limit and no roller dynamics;
  gravity and the contacts still decide whether it tips, and the push acts at floor level as a
  wheel's traction does.

The base's whole-body coordinates ``[x, y, yaw]`` are read from the free joint
(:class:`FloorSimModel`: yaw from the quaternion, unwrapped along the run; the yaw rate is the
world z component of the angular velocity). The floor model is not used for a ``fixed`` base
(an arm bolted down keeps the welded kinematic base).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, NamedTuple

import mujoco
import numpy as np

from forte.exceptions import SimulationError
from forte.execution.contact import SUPPORT
from forte.model.base_support import BaseSupport, box_support
from forte.model.robot import MobileManipulator
from forte.validation import FloatArray

#: The two base models of ``forte simulate`` (the first is the default).
BASE_MODELS = ("kinematic", "floor")
#: Drive wheel radius (m), mass (kg, taken from the base's) and reflected gearbox inertia (kg m^2).
WHEEL_RADIUS = 0.1
WHEEL_MASS = 1.0
WHEEL_ARMATURE = 0.05
#: Friction of the drive wheels on the floor (sliding, torsional, rolling): rubber, as Menagerie's Stretch.
WHEEL_FRICTION = (0.8, 0.02, 0.01)
#: Velocity-actuator gain of a drive wheel (N m s/rad): ``kv / r^2`` = 5000 N s/m at the rim.
WHEEL_KV = 50.0
#: Radius of a caster (or a holonomic base's contact) sphere (m).
CASTER_RADIUS = 0.03
#: Contact time constant of the casters (s; MuJoCo's ``solref``, the wheels keep MuJoCo's 0.02 s): softer,
#: as a suspension, so that the drive wheels carry a share of the weight: on the MOCA footprint at rest
#: 182 N each of 1660 N (37 N with casters as stiff as the wheels; measured).
CASTER_SOLREF = (0.05, 1.0)
#: Gains of the holonomic base's planar push ``F = kv (v_cmd - v)``: N s/m (x, y) and N m s/rad (yaw).
HOLONOMIC_KV = (2000.0, 2000.0, 400.0)
#: The base starts this far (m) into the floor: placed exactly on it, MuJoCo's first step had no
#: contact force (measured), a 1 ms drop that logged every contact as lifted.
START_SINK = 1e-4
#: A caster this close (m) to a wheel's contact point is the wheel's.
_SAME_POINT = 0.01


class Contact(NamedTuple):
    """One support contact: its geom's name (``wheel_left``, ``caster_2``), its point on the floor
    (base frame, m) and whether it is a driven wheel."""

    name: str
    point: tuple[float, float]
    wheel: bool


def floor_support(robot: MobileManipulator) -> BaseSupport:
    """The base the floor model carries: the robot's stated support, else forte's base box."""
    return robot.base_support if robot.base_support is not None else box_support(float(robot.mount[2, 3]))


def contact_layout(robot: MobileManipulator) -> tuple[Contact, ...]:
    """The support contacts (module docstring): the polygon's vertices, and for a differential
    base its two wheels where the line ``x = 0`` crosses the polygon's edge."""
    poly = floor_support(robot).polygon
    wheels: list[Contact] = []
    if robot.base == "differential":
        ys = _edge_crossings(poly)
        if ys is None:
            raise SimulationError("base_footprint: a differential base's wheel axle (x = 0) must cross the support "
                                  f"polygon {poly.tolist()}")
        wheels = [Contact("wheel_left", (0.0, ys[1]), True), Contact("wheel_right", (0.0, ys[0]), True)]
    casters = [Contact(f"caster_{i}", (float(x), float(y)), False) for i, (x, y) in enumerate(poly)
               if all(np.hypot(x - w.point[0], y - w.point[1]) > _SAME_POINT for w in wheels)]
    return (*wheels, *casters)


def _edge_crossings(poly: FloatArray) -> tuple[float, float] | None:
    """``(y_min, y_max)`` where the polygon's boundary crosses ``x = 0`` (None: it does not)."""
    ys = []
    for a, b in zip(poly, np.roll(poly, -1, axis=0), strict=True):
        if (a[0] - 0.0) * (b[0] - 0.0) <= 0 and a[0] != b[0]:
            ys.append(a[1] + (b[1] - a[1]) * (0.0 - a[0]) / (b[0] - a[0]))
        elif a[0] == 0.0 == b[0]:
            ys += [a[1], b[1]]
    if len(ys) < 2 or max(ys) - min(ys) < 1e-3:
        return None
    return float(min(ys)), float(max(ys))


def box_inertia(support: BaseSupport) -> list[float]:
    """Principal inertia (kg m^2) of a solid box of the support's mass over the footprint's
    bounding box, ``2 com_z`` high (at least 0.1 m): ``m (b^2 + c^2) / 12`` per axis."""
    poly = support.polygon
    a, b = np.ptp(poly[:, 0]), np.ptp(poly[:, 1])
    c = max(2.0 * support.com[2], 0.1)
    m = max(support.mass, 1e-3)
    return [m * (b**2 + c**2) / 12, m * (a**2 + c**2) / 12, m * (a**2 + b**2) / 12]


def add_floor_base(spec: mujoco.MjSpec, robot: MobileManipulator) -> Any:
    """The free base body with its support contacts and the ground plane (module docstring)."""
    support = floor_support(robot)
    layout = contact_layout(robot)
    n_wheels = sum(c.wheel for c in layout)
    wheel_mass = min(WHEEL_MASS, 0.05 * support.mass) if support.mass > 0 else 0.05
    body_mass = max(support.mass - n_wheels * wheel_mass, 1e-3)
    # elliptic friction cones, as Menagerie's Stretch: with pyramidal ones a wheel slipping on a 0.05 floor
    # unloaded the casters and chattered between contacts before the slip was judged (measured)
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    base = spec.worldbody.add_body(name="base", mass=body_mass, ipos=list(support.com),
                                   inertia=box_inertia(support), explicitinertial=True)
    base.add_freejoint(name="base_free")
    base.add_site(name="base_origin", pos=[0, 0, 0], size=[0.01, 0, 0], group=3)
    spec.worldbody.add_geom(name="ground", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[20, 20, 0.1], contype=0,
                            conaffinity=SUPPORT, rgba=[0, 0, 0, 0], group=3)
    for c in layout:
        if c.wheel:
            wheel = base.add_body(name=c.name, pos=[c.point[0], c.point[1], WHEEL_RADIUS], mass=wheel_mass,
                                  inertia=[0.25 * wheel_mass * WHEEL_RADIUS**2, 0.5 * wheel_mass * WHEEL_RADIUS**2,
                                           0.25 * wheel_mass * WHEEL_RADIUS**2], explicitinertial=True)
            wheel.add_joint(name=c.name, type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 1, 0], armature=WHEEL_ARMATURE)
            _support_geom(wheel, c.name, WHEEL_RADIUS, [0, 0, 0], condim=3, friction=list(WHEEL_FRICTION))
        else:
            _support_geom(base, c.name, CASTER_RADIUS, [c.point[0], c.point[1], CASTER_RADIUS], condim=1,
                          solref=list(CASTER_SOLREF))
    return base


def _support_geom(body: Any, name: str, radius: float, pos: list[float], condim: int,
                  friction: list[float] | None = None, solref: list[float] | None = None) -> None:
    extra = {k: v for k, v in (("friction", friction), ("solref", solref)) if v is not None}
    body.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[radius, 0, 0], pos=pos, contype=SUPPORT,
                  conaffinity=0, condim=condim, priority=1, mass=0.0, rgba=[0.15, 0.15, 0.15, 1], **extra)


def add_floor_actuators(spec: mujoco.MjSpec, robot: MobileManipulator) -> None:
    """Velocity actuators on the drive wheels (differential) or the planar push (holonomic)."""
    if robot.base == "differential":
        for c in contact_layout(robot):
            if c.wheel:
                act = spec.add_actuator(name=f"v_{c.name}", target=c.name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
                act.set_to_velocity(kv=WHEEL_KV)
        return
    for name, gear in (("push_x", [1, 0, 0, 0, 0, 0]), ("push_y", [0, 1, 0, 0, 0, 0]),
                       ("push_yaw", [0, 0, 0, 0, 0, 1])):
        act = spec.add_actuator(name=name, target="base_origin", trntype=mujoco.mjtTrn.mjTRN_SITE, gear=gear)
        act.set_to_motor()


def yaw_of(quat: FloatArray) -> float:
    """Yaw (rad, (-pi, pi]) of a MuJoCo quaternion ``(w, x, y, z)``: the heading of the body's x axis."""
    w, x, y, z = quat
    return float(np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)))


def roll_pitch(R: FloatArray) -> tuple[float, float]:
    """Roll and pitch (rad) of a rotation matrix ``R = Rz(yaw) Ry(pitch) Rx(roll)``."""
    return float(np.arctan2(R[2, 1], R[2, 2])), float(np.arcsin(np.clip(-R[2, 0], -1.0, 1.0)))


@dataclass
class FloorSimModel:
    """What a :class:`~forte.execution.model.SimModel` adds for a floor base (``sim.floor``).

    Attributes:
        drive: ``"differential"`` or ``"holonomic"``.
        contacts: The support contacts (:func:`contact_layout`).
        geoms: Their geom ids, in the same order.
        free_q, free_v: qpos / qvel address of the free joint.
        wheel_dofs: qvel address of each wheel hinge (differential; wheels first in ``contacts``).
        actuators: Ids of the wheel (``v_wheel_*``) or push actuators.
    """

    drive: str
    contacts: tuple[Contact, ...]
    geoms: np.ndarray
    free_q: int
    free_v: int
    wheel_dofs: np.ndarray
    actuators: np.ndarray
    unwrapped_yaw: float = field(default=0.0)

    @classmethod
    def index(cls, robot: MobileManipulator, model: mujoco.MjModel) -> FloorSimModel:
        layout = contact_layout(robot)
        free = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, "base_free")
        wheels = [c.name for c in layout if c.wheel]
        acts = [f"v_{w}" for w in wheels] if wheels else ["push_x", "push_y", "push_yaw"]
        act_ids = np.array([mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_ACTUATOR, a) for a in acts])
        geoms = np.array([mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, c.name) for c in layout])
        if free < 0 or act_ids.min() < 0 or geoms.min() < 0:
            raise SimulationError("simulation model: the floor base's joint, actuators or contacts were not all found")
        dofs = [model.jnt_dofadr[mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_JOINT, w)] for w in wheels]
        return cls("differential" if wheels else "holonomic", layout, geoms, int(model.jnt_qposadr[free]),
                   int(model.jnt_dofadr[free]), np.array(dofs, dtype=int), act_ids)

    def set_base(self, data: mujoco.MjData, q_b: FloatArray, dq_b: FloatArray) -> None:
        """Base pose ``[x, y, yaw]`` on the floor, level, with planar velocity ``dq_b``; wheels rolling."""
        a, v = self.free_q, self.free_v
        data.qpos[a:a + 7] = [q_b[0], q_b[1], -START_SINK, np.cos(q_b[2] / 2), 0.0, 0.0, np.sin(q_b[2] / 2)]
        data.qvel[v:v + 6] = [dq_b[0], dq_b[1], 0.0, 0.0, 0.0, dq_b[2]]
        self.unwrapped_yaw = float(q_b[2])
        c, s = np.cos(q_b[2]), np.sin(q_b[2])
        forward = c * dq_b[0] + s * dq_b[1]
        for contact, dof in zip(self.contacts, self.wheel_dofs, strict=False):
            data.qvel[dof] = (forward - dq_b[2] * contact.point[1]) / WHEEL_RADIUS

    def base_state(self, data: mujoco.MjData) -> tuple[FloatArray, FloatArray]:
        """``([x, y, yaw], [dx, dy, dyaw])``: world position of the base origin, yaw unwrapped from the
        last call, the origin's world velocity and the world z component of the angular velocity."""
        a, v = self.free_q, self.free_v
        yaw = yaw_of(data.qpos[a + 3:a + 7])
        self.unwrapped_yaw += (yaw - self.unwrapped_yaw + np.pi) % (2 * np.pi) - np.pi
        R = np.zeros(9)
        mujoco.mju_quat2Mat(R, data.qpos[a + 3:a + 7])
        omega = R.reshape(3, 3) @ data.qvel[v + 3:v + 6]
        return (np.array([data.qpos[a], data.qpos[a + 1], self.unwrapped_yaw]),
                np.array([data.qvel[v], data.qvel[v + 1], omega[2]]))


def uses_floor(robot: MobileManipulator, base_model: str) -> bool:
    """Whether ``base_model`` builds a base on the floor (a fixed base never does)."""
    return check_base_model(base_model) == "floor" and robot.base != "fixed"


def check_base_model(name: str) -> str:
    """``name`` is one of :data:`BASE_MODELS` (else one line)."""
    if name not in BASE_MODELS:
        from forte.exceptions import InvalidInputError

        raise InvalidInputError(f"base_model: expected one of {', '.join(BASE_MODELS)}, got {name!r}")
    return name


__all__ = ["BASE_MODELS", "CASTER_RADIUS", "Contact", "FloorSimModel", "WHEEL_RADIUS", "add_floor_actuators",
           "add_floor_base", "check_base_model", "contact_layout", "floor_support", "roll_pitch", "uses_floor",
           "yaw_of"]
