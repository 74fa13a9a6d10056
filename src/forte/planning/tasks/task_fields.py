"""Every field of a task file, declared once: dotted path, type, unit, default, range and meaning.

The readers (:mod:`forte.planning.tasks.tasks` and its section modules) check a task imperatively; this
list says the same declaratively, so that ``forte schema`` (a JSON Schema, :mod:`forte.io.task_schema`)
and the reference page ``docs/task-files.md`` are generated from it, and ``tests/test_task_schema.py``
compares it with what the readers accept (each mapping's fields, read from the readers' own
unknown-field errors). Paths: ``a.b`` is field ``b`` of mapping ``a``; ``a[].b`` is field ``b`` of
each item of the list ``a``. A field with ``when=(KEY, VALUE)`` belongs to the variant of its mapping
whose ``KEY`` is ``VALUE`` (required there when ``required``). The fields of the cost terms'
settings come from the terms' own declarations (:attr:`forte.planning.terms.costs.CostTerm.settings`).
"""

from __future__ import annotations

from typing import Any

from forte.force.contact import CONTACT_KINDS
from forte.force.payload import MAX_COM_OFFSET_M
from forte.force.taskforce import DEFAULT_RADIUS, FORCE_MODELS, RADIUS_RULES
from forte.model.occupancy_cover import DEFAULT_MAX_BOXES, DEFAULT_SLACK, DEFAULT_SLACK_VOXELS
from forte.model.presets import ROBOT_PRESETS
from forte.model.robot import BASE_MODES, STANDARD_GRAVITY
from forte.model.scene import SHAPE_KINDS
from forte.planning.tasks.contact_section import (
    MAX_BOX_SIZE,
    MAX_DAMPING,
    MAX_FRICTION,
    MAX_FRICTION_FORCE,
    MAX_STIFFNESS,
)
from forte.planning.tasks.goal_poses import MAX_VIAS
from forte.planning.tasks.goals import DEFAULT_GOAL_SAMPLES, GOAL_ANGLE_TOL, GOAL_POSITION_TOL
from forte.planning.tasks.keep_level import AXES
from forte.planning.tasks.scene_section import DEFAULT_CLEARANCE, MAX_LENGTH_M
from forte.planning.tasks.sensed_section import (
    DEFAULT_MAX_RANGE,
    DEFAULT_VOXEL,
    MAX_BOXES,
    MAX_SLACK,
    MAX_VOXEL,
    SENSED_KINDS,
)
from forte.planning.tasks.task_types import (
    BOOL,
    INERTIA,
    MAPPING,
    ROTATION,
    STRING,
    Field,
    Prose,
    Type,
    choice,
    either,
    integer,
    items_of,
    joint_values,
    matrix,
    nullable,
    number,
    vector,
)
from forte.planning.tasks.term_fields import term_fields, weights_fields
from forte.settings import SOLVER_BACKENDS, KinematicLimits, SolverOptions
from forte.validation import MAX_DURATION_S, MAX_MASS_KG, MAX_WAYPOINTS

__all__ = ["FIELDS", "Field", "Prose", "Type", "STRICT_VARIANTS", "task_fields"]

#: The task's modes (:data:`forte.planning.tasks.tasks.MODES`; a test checks they agree).
MODES = ("trajectory", "hold")
#: Mappings whose variants accept different fields (the reader refuses another variant's field).
STRICT_VARIANTS = frozenset({"contact", "path"})


MASS = number(above=0, high=MAX_MASS_KG)
DURATION = number(above=0, high=MAX_DURATION_S)
TIME = number(low=-MAX_DURATION_S, high=MAX_DURATION_S)
LENGTH = number(above=0, high=MAX_LENGTH_M)
VEC3 = vector(3)
ZERO3 = [0.0, 0.0, 0.0]
PER_ARM = "one per arm joint"
PER_DOF = "x, y, yaw, then one per arm joint"
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


def _rotation(prefix: str, default: str, when: Any = None) -> list[Field]:
    """``orientation`` of ``prefix`` (declared once per variant in ``when``, a list, when given)."""
    heads = [Field(f"{prefix}.orientation", ROTATION, "the end effector's orientation: rpy, quaternion or matrix",
                   default=Prose(default), when=w) for w in (when or [None])]
    return [*heads, Field(f"{prefix}.orientation.rpy", VEC3, "roll, pitch, yaw (used when given)", "rad"),
            Field(f"{prefix}.orientation.quaternion", vector(4), "a unit quaternion [x, y, z, w] (used when "
                  "given and rpy is not)"),
            Field(f"{prefix}.orientation.matrix", matrix(3, 3), "an orthonormal 3 x 3 rotation matrix")]


def _tolerance(prefix: str, what: str) -> list[Field]:
    return [Field(f"{prefix}.tolerance", MAPPING, what),
            Field(f"{prefix}.tolerance.position", number(above=0, high=1.0), "position tolerance", "m",
                  GOAL_POSITION_TOL),
            Field(f"{prefix}.tolerance.angle", number(above=0, high=3.141592653589793), "orientation tolerance",
                  "rad", GOAL_ANGLE_TOL)]


def _passing_fields() -> list[Field]:
    """``path.via`` and pick and place's ``path.goals``/``path.grasp`` (:mod:`forte.planning.tasks.goal_poses`)."""
    when = ("kind", "goal")
    at = Prose("by the straight-line distance along start, vias, goal")
    return [
        Field("path.via", items_of(min_items=1), "poses the end effector passes on the way to the goal, in order "
              f"(at most {MAX_VIAS}; each an NLP pose equality at one waypoint)", when=when),
        Field("path.via[].position", VEC3, "the via position (world)", "m", required=True),
        *_rotation("path.via[]", "the initial end-effector orientation"),
        *_tolerance("path.via[]", "how close the plan must pass the via"),
        Field("path.via[].time", DURATION, "when the via is passed (needs path.duration; all vias or none)", "s",
              at),
        Field("path.goals", items_of(min_items=2, exactly_one=("pose", "configuration")),
              "pick and place: goals in order (e.g. pre-grasp, grasp, place); the last ends the motion, the "
              "others are passed as vias (instead of pose or configuration)", when=when),
        Field("path.goals[].pose", MAPPING, "a goal pose of the end effector"),
        Field("path.goals[].pose.position", VEC3, "the goal position (world)", "m", required=True),
        *_rotation("path.goals[].pose", "the initial end-effector orientation"),
        Field("path.goals[].configuration", vector(), f"a whole-body goal configuration ({PER_DOF}; before the "
              "last: passed as its end-effector pose)", "m, m, rad, rad..."),
        *_tolerance("path.goals[]", "how close the plan must pass (end at) a goal pose"),
        Field("path.goals[].time", DURATION, "when the goal is passed (needs path.duration; not the last)", "s",
              at),
        Field("path.grasp", integer(0, MAX_VIAS - 2), "the index (from 0) of the goal where the payload attaches: "
              "its mass and force count from that goal's waypoint on, the approach is unloaded",
              default=Prose("the goal before the last"), when=when),
    ]


WAYPOINTS, SINE, TAUGHT, GOAL = (("kind", k) for k in ("waypoints", "windowed-sine", "taught", "goal"))
_PATH = [
    Field("path.kind", choice(("waypoints", "windowed-sine", "taught", "goal")), "how the path is given (goal: "
          "from the start to a configuration or pose, the path between them free)", default="waypoints"),
    Field("path.waypoints", items_of(min_items=2), "timed positions joined by quintic blends", required=True,
          when=WAYPOINTS),
    Field("path.waypoints[].t", TIME, "the time of the waypoint (increasing)", "s", required=True),
    Field("path.waypoints[].position", VEC3, "the end effector's position (world, or relative)", "m", required=True),
    *_rotation("path.waypoints[]", "the waypoint before's (the first: path.orientation); joined by slerp"),
    Field("path.relative", BOOL, "positions relative to the initial end-effector position", default=False,
          when=WAYPOINTS),
    Field("path.configurations", items_of(min_items=2), "timed whole-body configurations (their forward "
          "kinematics, joined by quintic blends and slerp)", required=True, when=TAUGHT),
    Field("path.configurations[].t", TIME, "the time of the configuration (increasing)", "s", required=True),
    Field("path.configurations[].q", vector(), f"the configuration ({PER_DOF})", "m, m, rad, rad...", required=True),
    Field("path.samples", integer(2, MAX_WAYPOINTS), "number of waypoints N (a goal: at least 4)",
          default=Prose(f"50 (a goal: {DEFAULT_GOAL_SAMPLES}), or from rate")),
    Field("path.rate", number(above=0), "waypoints per second (when samples is absent)", "1/s"),
    *_rotation("path", "the initial end-effector orientation", [WAYPOINTS, SINE, TAUGHT]),
    Field("path.configuration", vector(), f"the goal configuration ({PER_DOF}; a fixed base: the start's base)",
          "m, m, rad, rad...", when=GOAL),
    Field("path.pose", MAPPING, "the goal pose of the end effector (instead of configuration)", when=GOAL),
    Field("path.pose.position", VEC3, "the goal position (world)", "m", required=True),
    *_rotation("path.pose", "the initial end-effector orientation"),
    Field("path.tolerance", MAPPING, "how close the plan must end to a goal pose", when=GOAL),
    Field("path.tolerance.position", number(above=0, high=1.0), "position tolerance", "m", GOAL_POSITION_TOL),
    Field("path.tolerance.angle", number(above=0, high=3.141592653589793), "orientation tolerance", "rad",
          GOAL_ANGLE_TOL),
    *_passing_fields(),
    Field("path.duration", DURATION, "the motion's duration", "s", Prose("from the joints' velocity and "
          "acceleration limits, at least 1 s"), when=GOAL),
    Field("path.duration", DURATION, "the sine path's duration", "s", required=True, when=SINE),
    Field("path.offset", VEC3, "c in w(t) (c + a sin(2 pi f t + phi))", "m", ZERO3, when=SINE),
    Field("path.amplitude", VEC3, "a in w(t) (c + a sin(2 pi f t + phi))", "m", required=True, when=SINE),
    Field("path.frequency", VEC3, "f in w(t) (c + a sin(2 pi f t + phi))", "Hz", required=True, when=SINE),
    Field("path.phase", VEC3, "phi in w(t) (c + a sin(2 pi f t + phi))", "rad", ZERO3, when=SINE),
    Field("path.keep_level", MAPPING, "keep a tool axis near a world axis along the whole plan (a tray, an open "
          "cup; any path kind): arccos(w . R a) <= max_tilt", default=Prose("none")),
    Field("path.keep_level.axis", choice(AXES), "the world axis w (sign included: z is up)", default="z"),
    Field("path.keep_level.max_tilt_deg", number(above=0, below=180), "the largest angle between the tool axis "
          "and the world axis", "deg", required=True),
    Field("path.keep_level.tool_axis", choice(AXES), "the end effector's axis a (-z: a hand pointing down)",
          default="z"),
]

_POSE = [
    Field("pose.position", VEC3, "the end effector's position to hold (world, or relative)", "m", required=True),
    Field("pose.relative", BOOL, "position relative to the initial end-effector position", default=False),
    *_rotation("pose", "the initial end-effector orientation"),
]

_PAYLOAD = [
    Field("payload.mass", number(low=0, high=MAX_MASS_KG), "the payload's mass (--mass overrides it; 0: an empty "
          "hand)", "kg"),
    Field("payload.description", STRING, "words for the mass estimator (forte estimate)"),
    Field("payload.image", STRING, "an image for the mass estimator (PNG, JPEG, WebP or GIF; relative to the task "
          "file)"),
    Field("payload.com", vector(3, norm=MAX_COM_OFFSET_M), "the payload's centre of mass in the end-effector frame",
          "m", Prose("at the hand")),
    Field("payload.inertia", INERTIA, "the payload's inertia about its centre of mass, end-effector axes", "kg m^2",
          Prose("none")),
    Field("payload.moment_scale", number(above=0, high=MAX_COM_OFFSET_M), "length that scales moments against "
          "forces in the wrench metric", "m", Prose("|com|")),
]

CONSTANT = ("kind", "constant")
_FORCE = [
    Field("force.kind", choice(("constant", "windowed-sine")), "how the profile is given", default="constant"),
    Field("force.vector", VEC3, "the constant force", "N", required=True, when=CONSTANT),
    Field("force.duration", DURATION, "the window's length (at least the path's)", "s", Prose("the path's span"),
          when=SINE),
    Field("force.offset", VEC3, "c in w(t) (c + a sin(2 pi f t + phi))", "N", ZERO3, when=SINE),
    Field("force.amplitude", VEC3, "a in w(t) (c + a sin(2 pi f t + phi))", "N", required=True, when=SINE),
    Field("force.frequency", VEC3, "f in w(t) (c + a sin(2 pi f t + phi))", "Hz", required=True, when=SINE),
    Field("force.phase", VEC3, "phi in w(t) (c + a sin(2 pi f t + phi))", "rad", ZERO3, when=SINE),
]

PUSH, DRAWER, CARRY = (("kind", k) for k in CONTACT_KINDS)
_CONTACT = [
    Field("contact.kind", choice(CONTACT_KINDS), "the contact model (forte.force.contact)", required=True),
    Field("contact.mass", MASS, "the box's, drawer's or carried object's mass", "kg", required=True),
    Field("contact.friction", number(above=0, high=MAX_FRICTION), "the box's friction coefficient on the floor",
          required=True, when=PUSH),
    Field("contact.size", vector(3, above=0, high=MAX_BOX_SIZE), "the box's edge lengths", "m", [0.4, 0.4, 0.4],
          when=PUSH),
    Field("contact.stiffness", number(low=0, high=MAX_STIFFNESS), "the drawer's spring", "N/m", 0.0, when=DRAWER),
    Field("contact.damping", number(low=0, high=MAX_DAMPING), "the drawer's damper", "N s/m", 0.0, when=DRAWER),
    Field("contact.friction", number(low=0, high=MAX_FRICTION_FORCE), "the drawer's Coulomb friction", "N", 0.0,
          when=DRAWER),
    Field("contact.rest", number(), "the drawer spring's rest position along the path", "m", 0.0, when=DRAWER),
    Field("contact.com", vector(3, norm=MAX_COM_OFFSET_M), "the object's centre of mass in the end-effector frame",
          "m", required=True, when=CARRY),
    Field("contact.partner", vector(3, norm=MAX_COM_OFFSET_M), "the partner's grip in the end-effector frame", "m",
          required=True, when=CARRY),
    Field("contact.share", number(low=0, high=1.0), "the weight's share the hand carries",
          default=Prose("from com and partner"), when=CARRY),
    Field("contact.release_time", number(low=0, high=MAX_DURATION_S), "when the partner lets go", "s",
          Prose("never"), when=CARRY),
    Field("contact.release_duration", DURATION, "how long the release takes", "s", 0.5, when=CARRY),
]

_SHAPES = {
    "box": [Field("scene[].box.size", vector(3, above=0, high=MAX_LENGTH_M), "edge lengths", "m", required=True)],
    "cylinder": [Field("scene[].cylinder.radius", LENGTH, "radius", "m", required=True),
                 Field("scene[].cylinder.length", LENGTH, "length along its z axis", "m", required=True)],
    "sphere": [Field("scene[].sphere.radius", LENGTH, "radius", "m", required=True)],
    "capsule": [Field("scene[].capsule.radius", LENGTH, "radius", "m", required=True),
                Field("scene[].capsule.length", LENGTH, "length of its axis along z", "m", required=True)],
    "mesh": [Field("scene[].mesh.file", STRING, "a mesh file (STL, OBJ, ...; relative to the task file)",
                   required=True),
             Field("scene[].mesh.scale", either(number(above=0), vector(3, above=0)), "scale factors (one or x, y, z)",
                   default=1.0)],
}
_VOXEL = number(above=0, high=MAX_VOXEL)


def _merge(kind: str) -> list[Field]:
    """The sensed entry's ``merge`` (:func:`forte.planning.tasks.sensed_section.merge_settings`)."""
    return [Field(f"scene[].{kind}.merge", either(choice(("exact",)), MAPPING), "how the occupied voxels become "
                  "boxes: exact (their union is the voxels) or a coarse cover {slack, max_boxes} (boxes holding "
                  "every voxel and free space only within slack of one)", default=Prose("the cover's defaults")),
            Field(f"scene[].{kind}.merge.slack", number(low=0, high=MAX_SLACK), "the cover's boxes stay within "
                  "this of an occupied voxel (until max_boxes)", "m",
                  Prose(f"{DEFAULT_SLACK_VOXELS} voxels, at least {DEFAULT_SLACK:g} m")),
            Field(f"scene[].{kind}.merge.max_boxes", integer(1, MAX_BOXES), "the most boxes of the cover",
                  default=DEFAULT_MAX_BOXES)]


_SENSED = [
    Field("scene[].capture_configuration", vector(), "the robot's whole-body configuration when the sensor "
          "data was taken: points on the robot are removed (point_cloud, depth_image only)", "m, m, rad, rad...",
          Prose("no self-filter")),
    Field("scene[].point_cloud", MAPPING, "a point cloud whose occupied voxels become boxes"),
    Field("scene[].point_cloud.file", STRING, "a .ply, .pcd or .npy (N x 3) file (relative to the task file)",
          required=True),
    Field("scene[].point_cloud.voxel", _VOXEL, "voxel size", "m", DEFAULT_VOXEL),
    *_merge("point_cloud"),
    Field("scene[].depth_image", MAPPING, "a depth image (pose: the camera's optical frame, z forward, x right, "
          "y down) whose occupied voxels become boxes"),
    Field("scene[].depth_image.file", STRING, "a .png (grey) or .npy (H x W) file (relative to the task file)",
          required=True),
    Field("scene[].depth_image.scale", number(above=0), "metres per image unit",
          default=Prose("0.001 for .png, 1 for .npy")),
    Field("scene[].depth_image.intrinsics", MAPPING, "the pinhole camera: fx, fy, cx, cy (pixels)", required=True),
    *(Field(f"scene[].depth_image.intrinsics.{k}", number(above=0) if k[0] == "f" else number(), what, "px",
            required=True) for k, what in (("fx", "focal length along x"), ("fy", "focal length along y"),
                                           ("cx", "principal point's column"), ("cy", "principal point's row"))),
    Field("scene[].depth_image.max_range", number(above=0, high=1000.0), "depths beyond it are no return", "m",
          DEFAULT_MAX_RANGE),
    Field("scene[].depth_image.voxel", _VOXEL, "voxel size", "m", DEFAULT_VOXEL),
    *_merge("depth_image"),
]
_SCENE = [
    Field("scene[].name", STRING, "the body's name (unique)", default=Prose("body<i>")),
    Field("scene[].pose", vector(6), "x, y, z, roll, pitch, yaw in the world", "m, rad", required=True),
    *(f for kind in SHAPE_KINDS for f in [Field(f"scene[].{kind}", MAPPING, f"a {kind} (exactly one shape per "
                                                "body)"), *_SHAPES[kind]]),
    *_SENSED,
    Field("floor.height", number(low=-MAX_LENGTH_M, high=MAX_LENGTH_M), "the floor's height (world z)", "m",
          required=True),
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
}
_LIMIT_DOCS = {
    "enabled": (BOOL, "false: the paper's NLP exactly (no velocity or acceleration limits)", ""),
    "end_at_rest": (BOOL, "zero velocity and acceleration at the last waypoint", ""),
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
]


def task_fields() -> list[Field]:
    """Every field, in the order of the reference page (the cost terms' as registered now)."""
    solver, limits = SolverOptions(), KinematicLimits()
    return [*_TOP, *_ROBOT, *_PATH, *_POSE, *_PAYLOAD, *_FORCE, *_CONTACT, *_SCENE,
            *weights_fields(), *term_fields(),
            *(Field(f"solver.{k}", t, d, u, getattr(solver, k)) for k, (t, d, u) in _SOLVER_DOCS.items()),
            *(Field(f"limits.{k}", t, d, u, _LIMIT_DEFAULTS.get(k, _json(getattr(limits, k))))
              for k, (t, d, u) in _LIMIT_DOCS.items()),
            *_CONTROLLER]


def _json(value: Any) -> Any:
    return list(value) if isinstance(value, tuple) else value


FIELDS: tuple[Field, ...] = tuple(task_fields())
