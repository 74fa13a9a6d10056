"""Every field of a task file, declared once: dotted path, type, unit, default, range and meaning.

The readers (:mod:`forte.planning.tasks.tasks` and its section modules) check a task imperatively; this
list says the same declaratively, so that ``forte schema`` (a JSON Schema, :mod:`forte.io.task_schema`)
and the reference page ``docs/task-files.md`` are generated from it, and ``tests/test_task_schema.py``
compares it with what the readers accept (each mapping's fields, read from the readers' own
unknown-field errors). Paths: ``a.b`` is field ``b`` of mapping ``a``; ``a[].b`` is field ``b`` of
each item of the list ``a``. A field with ``when=(KEY, VALUE)`` belongs to the variant of its mapping
whose ``KEY`` is ``VALUE`` (required there when ``required``). The fields of the cost terms'
settings come from the terms' own declarations (:attr:`forte.planning.terms.costs.CostTerm.settings`).

The sections live beside this table: ``path`` and ``pose`` in :mod:`forte.planning.tasks.path_fields`;
``payload``, ``force``, ``contact``, ``scene`` and ``floor`` in :mod:`forte.planning.tasks.world_fields`;
weights and terms in :mod:`forte.planning.tasks.term_fields`; the top level, ``robot``, ``solver``,
``limits`` and ``controller`` here. The types and the units the sections share are defined
in :mod:`forte.planning.tasks.task_types`.
"""

from __future__ import annotations

from typing import Any

from forte.force.taskforce import DEFAULT_RADIUS, FORCE_MODELS, RADIUS_RULES
from forte.model.presets import ROBOT_PRESETS
from forte.model.robot import BASE_MODES, STANDARD_GRAVITY
from forte.model.scene import SHAPE_KINDS
from forte.planning.tasks.path_fields import PATH_FIELDS, POSE_FIELDS
from forte.planning.tasks.scene_section import DEFAULT_CLEARANCE
from forte.planning.tasks.sensed_section import SENSED_KINDS
from forte.planning.tasks.task_types import (
    BOOL,
    INERTIA,
    MAPPING,
    MASS,
    PER_ARM,
    PER_DOF,
    STRING,
    VEC3,
    ZERO3,
    Field,
    Prose,
    Type,
    choice,
    either,
    integer,
    items_of,
    joint_values,
    nullable,
    number,
    vector,
)
from forte.planning.tasks.term_fields import term_fields, weights_fields
from forte.planning.tasks.world_fields import CONTACT_FIELDS, FORCE_FIELDS, PAYLOAD_FIELDS, SCENE_FIELDS
from forte.settings import SOLVER_BACKENDS, KinematicLimits, SolverOptions
from forte.validation import MAX_MASS_KG

__all__ = ["FIELDS", "Field", "Prose", "Type", "STRICT_VARIANTS", "task_fields"]

#: The task's modes (:data:`forte.planning.tasks.tasks.MODES`; a test checks they agree).
MODES = ("trajectory", "hold")
#: Mappings whose variants accept different fields (the reader refuses another variant's field).
STRICT_VARIANTS = frozenset({"contact", "path"})

TRAJ, HOLD = ("mode", "trajectory"), ("mode", "hold")

_TOP = [
    Field("name", STRING, "the task's name (plan.json, figures)", default=Prose("the file's stem")),
    Field("robot", MAPPING, "the robot (a preset, or your URDF)", default=Prose("the built-in robot (preset authors)")),
    Field("mode", choice(MODES), "plan a trajectory along a path, or one holding configuration", default="trajectory"),
    Field("initial_configuration", vector(), f"the start configuration ({PER_DOF})", "m, m, rad, rad...",
          Prose("the robot's home")),
    Field("path", MAPPING, "the end-effector path (required in mode trajectory)", required=True, when=TRAJ),
    Field("pose", MAPPING, "the end-effector pose to hold (mode hold; or teaching_configuration)", when=HOLD),
    Field("teaching_configuration", vector(), f"a configuration reaching the hold pose ({PER_DOF})",
          "m, m, rad, rad...", when=HOLD),
    Field("payload", MAPPING, "the payload: a mass, or a description and an image for the estimator",
          default=Prose("none: an empty hand (the robot's tool load only)")),
    Field("force", MAPPING, "a force profile given directly (with a payload too: the profile plus its force)"),
    Field("contact", MAPPING, "a contact-rich task (push a box, open a drawer, carry with a partner)"),
    Field("uncertainty_radius", number(low=0, high=1e6), "radius r of the force uncertainty ball", "N",
          Prose(f"{DEFAULT_RADIUS:g}; 0 with an empty hand (no payload, force or contact)")),
    Field("uncertainty_rule", choice(RADIUS_RULES), "fixed: r everywhere; mass-range: the ball covers the mass "
          "estimate's range (never below r)", default="fixed"),
    Field("force_model", choice(FORCE_MODELS), "paper: (m + m_tool)(p'' - g) from t = 0; authors: (m + m_tool) g "
          "blended in over 1 s", default="paper"),
    Field("weights", MAPPING, "the weight set and the cost terms' weights"),
    Field("terms", MAPPING, "cost terms added to every optimized method, and term settings"),
    Field("torque_limits", vector(low=0), f"the arm's torque limits ({PER_ARM}; or robot.torque_limits)", "Nm",
          Prose("the robot's")),
    Field("solver", MAPPING, "IPOPT and build options"),
    Field("limits", MAPPING, "joint velocity and acceleration limits of the planned motion"),
    Field("controller", MAPPING, "gains of the impedance controller 'forte simulate' runs"),
    Field("require_capacity", BOOL, "obsolete: every plan's verdict requires capacity (still read)", default=False),
    Field("scene", items_of(exactly_one=(*SHAPE_KINDS, *SENSED_KINDS)), "static bodies around the robot",
          default=Prose("none: free space")),
    Field("scene_file", STRING, "a URDF or MJCF file whose static bodies join the scene (relative to the task file)"),
    Field("clearance", number(low=0, high=1.0), "distance the plan keeps from every body and the floor", "m",
          DEFAULT_CLEARANCE),
    Field("floor", either(choice(("none",)), MAPPING), "the floor: {height: h} or none", default=Prose("height 0")),
]

_ROBOT = [
    Field("robot.preset", choice(tuple(ROBOT_PRESETS)), "a built-in robot (its URDF, mount, tool, limits)",
          default="authors"),
    Field("robot.urdf", STRING, "your arm's URDF: a path relative to the task file, or erd:<path inside "
          "example-robot-data>", needs=("ee_frame",)),
    Field("robot.ee_frame", STRING, "the end-effector frame of the URDF (required with urdf)"),
    Field("robot.arm_joints", vector(of=STRING), "the arm's joints, in order", default=Prose("the URDF's")),
    Field("robot.locked_joints", Type("mapping", {"type": "object", "additionalProperties": {"type": "number"}},
                                      "joint name: value"),
          "joints that are not planned (e.g. fingers), held at these values (clipped to the URDF's range)",
          "rad or m", Prose("neutral, clipped to the range")),
    Field("robot.mount", MAPPING, "where the arm sits on the base"),
    Field("robot.mount.xyz", VEC3, "the arm's position in the base frame", "m", ZERO3),
    Field("robot.mount.rpy", VEC3, "the arm's orientation in the base frame (roll, pitch, yaw)", "rad", ZERO3),
    Field("robot.tool", nullable(MAPPING), "the tool's load on the flange (null: none)", default=Prose("the preset's")),
    Field("robot.tool.mass", MASS, "the tool's mass", "kg", required=True),
    Field("robot.tool.com", VEC3, "the tool's centre of mass in the flange frame", "m", ZERO3),
    Field("robot.tool.inertia", INERTIA, "the tool's inertia about its centre of mass", "kg m^2", Prose("zero")),
    Field("robot.torque_limits", vector(low=0), f"the arm's torque limits ({PER_ARM})", "Nm",
          Prose("the URDF's efforts")),
    Field("robot.gravity", number(above=0, high=1000.0), "gravitational acceleration along -z", "m/s^2",
          STANDARD_GRAVITY),
    Field("robot.name", STRING, "the robot's name", default=Prose("the preset's or the URDF's")),
    Field("robot.tool_force_mass", number(low=0), "mass whose weight the task force adds (the authors' end-effector "
          "load)", "kg", Prose("the preset's")),
    Field("robot.home_arm", vector(), f"the arm's home posture ({PER_ARM})", "rad", Prose("the preset's or zeros")),
    Field("robot.acceleration_limits", vector(low=0), f"the arm's acceleration limits ({PER_ARM})", "rad/s^2",
          Prose("the preset's, else none")),
    Field("robot.base", choice(BASE_MODES), "how the base moves", default="holonomic"),
    Field("robot.base_footprint", nullable(either(choice(("box",)), vector(of=vector(2)))),
          "the base's support polygon: [x, y] vertices in the base frame, box (forte's base box) or null",
          "m", Prose("the preset's")),
    Field("robot.base_mass", number(low=0, high=MAX_MASS_KG), "the base's mass (tip-over)", "kg",
          Prose("the footprint's")),
    Field("robot.base_com", VEC3, "the base's centre of mass in the base frame (tip-over)", "m",
          Prose("the footprint's")),
]


_SOLVER_DOCS = {
    "max_iter": (integer(1, 10**9), "IPOPT iteration limit (a goal task: 200 unless given)", ""),
    "tol": (number(above=0, high=1e12), "IPOPT convergence tolerance", ""),
    "constraint_tol": (number(above=0, high=1e12), "accepted constraint violation of a successful result", ""),
    "codegen": (BOOL, "generate, compile and cache C code for the NLP (a C compiler; else the CasADi VM)", ""),
    "cache_dir": (nullable(STRING), "where compiled problems are kept ($FORTE_CACHE or ~/.cache/forte when null)", ""),
    "print_level": (integer(0, 12), "IPOPT verbosity (0: silent)", ""),
    "hold_starts": (integer(1, 10**9), "starts of a hold problem (the best converged one wins; 1: the authors')", ""),
    "hold_seed": (integer(0, 10**9), "seed of the extra hold starts", ""),
    "refine_rounds": (integer(0, 10**9), "rounds of verdict-driven refinement (0: the NLP's optimum)", ""),
    "backend": (choice(SOLVER_BACKENDS), "the NLP solver: IPOPT or forte's stage-structured interior point", ""),
    "route_first": (BOOL, "a goal task: its route becomes the plan without the NLP when the verdict passes it "
                          "(fast; capacity checked, not optimized)", ""),
    "time_budget_s": (nullable(number(above=0, high=1e6)), "CPU seconds of the whole plan: guess, solves, rounds "
                      "(wall: 2.5 x; null: 120; a goal task: 4 unless given, then its route if feasible)", "s"),
}
_LIMIT_DOCS = {
    "enabled": (BOOL, "false: the paper's NLP exactly (no velocity or acceleration limits)", ""),
    "end_at_rest": (BOOL, "zero velocity and acceleration at the last waypoint", ""),
    "on_spline": (nullable(BOOL), "bound the arm's velocities and accelerations on the executed spline too "
                                  "(null: on, but off for online re-planning)", ""),
    "arm_velocity": (joint_values(above=0), f"{PER_ARM}, or {{joint: value}}", "rad/s"),
    "arm_acceleration": (joint_values(above=0), f"{PER_ARM}, or {{joint: value}}", "rad/s^2"),
    "base_velocity": (vector(3, above=0), "x, y, yaw", "m/s, m/s, rad/s"),
    "base_acceleration": (vector(3, above=0), "x, y, yaw", "m/s^2, m/s^2, rad/s^2"),
}
_LIMIT_DEFAULTS = {"arm_velocity": Prose("the URDF's"), "arm_acceleration": Prose("robot.acceleration_limits")}
_ARM_GAIN, _BASE_GAIN = either(number(low=0), vector(low=0)), either(number(low=0), vector(3, low=0))
_CONTROLLER = [
    Field("controller.bandwidth_hz", number(above=0), "natural frequency of the gain rule K = M omega^2", "Hz", 4.0),
    Field("controller.damping_ratio", number(above=0), "damping ratio of the gain rule", "", 1.0),
    Field("controller.K_a", _ARM_GAIN, f"arm stiffness ({PER_ARM}, or one for all)", "Nm/rad", Prose("the rule's")),
    Field("controller.D_a", _ARM_GAIN, f"arm damping ({PER_ARM}, or one for all)", "Nm s/rad", Prose("the rule's")),
    Field("controller.M_b", either(number(above=0), vector(3, above=0)), "base inertia (x, y, yaw, or one for all)",
          "kg, kg m^2", Prose("ControlGains'")),
    Field("controller.B_b", _BASE_GAIN, "base damping (x, y, yaw, or one for all)", "N s/m, Nm s/rad",
          Prose("ControlGains'")),
    Field("controller.K_b", _BASE_GAIN, "base stiffness (x, y, yaw, or one for all)", "N/m, Nm/rad",
          Prose("ControlGains'")),
    Field("controller.D_b", _BASE_GAIN, "base damping on the error (x, y, yaw, or one for all)", "N s/m, Nm s/rad",
          Prose("ControlGains'")),
    Field("controller.base_feedforward", BOOL, "add the planned base velocity as feedforward", default=True),
    Field("controller.force_feedforward", BOOL, "add J^T f_d to the arm torques", default=True),
    Field("controller.base_coupling", BOOL, "the arm's feedforward with the base's motion (whole-body inverse "
          "dynamics)", default=False),
    Field("controller.force_along_reference", BOOL, "a payload's force m (p'' - g) fed forward on the executed "
          "reference's hand acceleration (false: the plan's waypoint forces, linear in time)", default=True),
]


def task_fields() -> list[Field]:
    """Every field, in the order of the reference page (the cost terms' as registered now)."""
    solver, limits = SolverOptions(), KinematicLimits()
    return [*_TOP, *_ROBOT, *PATH_FIELDS, *POSE_FIELDS, *PAYLOAD_FIELDS, *FORCE_FIELDS, *CONTACT_FIELDS, *SCENE_FIELDS,
            *weights_fields(), *term_fields(),
            *(Field(f"solver.{k}", t, d, u, getattr(solver, k)) for k, (t, d, u) in _SOLVER_DOCS.items()),
            *(Field(f"limits.{k}", t, d, u, _LIMIT_DEFAULTS.get(k, _json(getattr(limits, k))))
              for k, (t, d, u) in _LIMIT_DOCS.items()),
            *_CONTROLLER]


def _json(value: Any) -> Any:
    return list(value) if isinstance(value, tuple) else value


FIELDS: tuple[Field, ...] = tuple(task_fields())
