"""The task file's ``path`` and ``pose`` sections (:mod:`forte.planning.tasks.task_fields` says how a
field is declared; the readers are :mod:`forte.planning.tasks.paths`, :mod:`forte.planning.tasks.goals`,
:mod:`forte.planning.tasks.goal_poses` and :mod:`forte.planning.tasks.keep_level`): :data:`PATH_FIELDS`,
:data:`POSE_FIELDS`."""

from __future__ import annotations

from typing import Any

from forte.planning.tasks.goal_poses import MAX_VIAS
from forte.planning.tasks.goals import DEFAULT_GOAL_SAMPLES, GOAL_ANGLE_TOL, GOAL_POSITION_TOL
from forte.planning.tasks.keep_level import AXES
from forte.planning.tasks.task_types import (
    BOOL,
    DURATION,
    MAPPING,
    PER_DOF,
    ROTATION,
    SINE,
    VEC3,
    ZERO3,
    Field,
    Prose,
    choice,
    integer,
    items_of,
    matrix,
    number,
    vector,
)
from forte.validation import MAX_DURATION_S, MAX_WAYPOINTS

TIME = number(low=-MAX_DURATION_S, high=MAX_DURATION_S)


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


WAYPOINTS, TAUGHT, GOAL = (("kind", k) for k in ("waypoints", "taught", "goal"))
PATH_FIELDS = [
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

POSE_FIELDS = [
    Field("pose.position", VEC3, "the end effector's position to hold (world, or relative)", "m", required=True),
    Field("pose.relative", BOOL, "position relative to the initial end-effector position", default=False),
    *_rotation("pose", "the initial end-effector orientation"),
]


__all__ = ["PATH_FIELDS", "POSE_FIELDS"]
