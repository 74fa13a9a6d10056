"""``path.keep_level``: an orientation constraint along the whole plan (a tray or an open cup).

``keep_level: {axis: z, max_tilt_deg: 10, tool_axis: z}`` asks that the end effector's
``tool_axis`` (its own frame; default ``z``) stays within ``max_tilt_deg`` of the world's ``axis``
(default ``z``), sign included: with ``R`` the end effector's world rotation, ``a`` the tool axis
and ``w`` the world axis (unit vectors), the tilt is

    ``tilt = arccos(w . R a)  <=  max_tilt``            (:func:`tilt_angles`, exact)

and a cup whose axis points down is 180 degrees from upright, not 0. An axis is ``x``, ``y`` or
``z`` with an optional sign (``-z``: a hand whose z axis points down, as the built-in robot's
at home, keeps ``tool_axis: -z``). It lives under ``path:`` and applies to every path kind:

- the NLP keeps it at every waypoint whose orientation it chooses (a goal task's free path) by
  one smooth inequality row per waypoint, ``w . R(q_k) a >= cos(max_tilt)``
  (:mod:`forte.planning.nlp.keep_level_rows`), the same condition as the tilt's since ``arccos``
  decreases;
- where the task fixes the orientation (the waypoints of a given path, a goal pose or
  configuration, the start) the reader checks the given orientations instead (:func:`check_poses`):
  a row there would be implied by the pose equality, and dependent on it where active;
- the verdict judges the tilt on the executed spline, between waypoints too
  (:class:`forte.planning.verdict.keep_level.TiltLimit`).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from forte.model.robot import MobileManipulator
from forte.planning.tasks.schema import Reader
from forte.validation import FloatArray

#: The fields of ``path.keep_level``.
KEEP_LEVEL_FIELDS = frozenset({"axis", "max_tilt_deg", "tool_axis"})
#: The axes ``axis`` and ``tool_axis`` may name.
AXES = ("x", "y", "z", "-x", "-y", "-z")


class KeepLevel(NamedTuple):
    """A tool axis kept near a world axis (module docstring).

    Attributes:
        world_axis, tool_axis: unit vectors ``w`` (world frame) and ``a`` (end-effector frame).
        max_tilt: the largest angle (rad) between ``R a`` and ``w``, in (0, pi).
        world_name, tool_name: the axes as written (``z``, ``-z``), for messages.
    """

    world_axis: FloatArray
    tool_axis: FloatArray
    max_tilt: float
    world_name: str = "z"
    tool_name: str = "z"

    @property
    def min_cosine(self) -> float:
        """``cos(max_tilt)``: the rows' lower bound."""
        return float(np.cos(self.max_tilt))

    def describe(self) -> str:
        return f"the end effector's {self.tool_name} axis within {np.degrees(self.max_tilt):g} deg of world " \
               f"{self.world_name}"


def axis_vector(name: str) -> FloatArray:
    """``x``, ``-z``, ... as a unit vector."""
    sign = -1.0 if name.startswith("-") else 1.0
    out = np.zeros(3)
    out["xyz".index(name[-1])] = sign
    return out


def _axis(r: Reader, name: str) -> str:
    value = r.get(name, "z")
    if value not in AXES:
        raise r.error(name, f"expected one of {', '.join(AXES)}, got {value!r}")
    return str(value)


def read_keep_level(path: Reader) -> KeepLevel | None:
    """``path.keep_level`` (``path``: the reader of ``path:``), or ``None`` when absent."""
    if not path.has("keep_level"):
        return None
    if not isinstance(path.get("keep_level"), dict):
        raise path.error("keep_level", f"expected a mapping {{axis, max_tilt_deg, tool_axis}}, got "
                         f"{path.get('keep_level')!r}")
    r = path.sub("keep_level")
    r.unknown(set(KEEP_LEVEL_FIELDS))
    world, tool = _axis(r, "axis"), _axis(r, "tool_axis")
    tilt = r.number("max_tilt_deg")
    if not 0.0 < tilt < 180.0:
        raise r.error("max_tilt_deg", f"expected an angle in degrees > 0 and < 180, got {tilt:g}")
    return KeepLevel(axis_vector(world), axis_vector(tool), float(np.radians(tilt)), world, tool)


def tilt_angles(keep: KeepLevel, rotations: FloatArray) -> FloatArray:
    """``arccos(w . R_k a)`` (rad) for every rotation ``R_k`` (K x 3 x 3): the exact tilt."""
    R = np.asarray(rotations, dtype=float).reshape(-1, 3, 3)
    cos = np.einsum("i,kij,j->k", keep.world_axis, R, keep.tool_axis)
    return np.arccos(np.clip(cos, -1.0, 1.0))


def check_poses(r: Reader, keep: KeepLevel | None, poses: FloatArray, times: FloatArray, what: str) -> None:
    """One error naming the first of ``poses`` (K x 4 x 4 or K x 3 x 3, at ``times``) that tilts
    beyond ``keep``: orientations the task itself fixes (``what`` says which)."""
    if keep is None:
        return
    poses = np.asarray(poses, dtype=float)
    tilt = tilt_angles(keep, poses[:, :3, :3])
    bad = np.flatnonzero(tilt > keep.max_tilt + 1e-9)
    if bad.size:
        k = int(bad[0])
        hint = "; a tool axis that points the other way is written with a sign (tool_axis: -z)" \
            if tilt[k] > np.pi / 2 else ""
        at = f" at t = {times[k]:.3g} s" if len(poses) > 1 else ""
        raise r.error("keep_level", f"{what}{at} tilts {np.degrees(tilt[k]):.4g} deg from world {keep.world_name} "
                      f"(tool axis {keep.tool_name}); expected at most max_tilt_deg "
                      f"{np.degrees(keep.max_tilt):g}{hint}")


def keep_level_section(reader: Reader, robot: MobileManipulator, q_init: FloatArray, t: FloatArray,
                       targets: FloatArray, goal: Any) -> KeepLevel | None:
    """``path.keep_level`` of a trajectory task, with the orientations the task fixes checked
    against it: the start, and a given path's targets at every sample, or a goal's pose (a
    configuration goal: its end effector's)."""
    path = reader.get("path")
    if not isinstance(path, dict) or path.get("keep_level") is None:
        return None
    r = reader.sub("path")
    keep = read_keep_level(r)
    check_poses(r, keep, robot.ee_pose(q_init)[None], t[:1], "the start (the end effector at initial_configuration)")
    if goal is None:
        check_poses(r, keep, targets, t, "the given path")
    elif goal.pose is not None:
        check_poses(r, keep, goal.pose[None], t[-1:], "the goal pose")
    else:
        check_poses(r, keep, robot.ee_pose(goal.q_end)[None], t[-1:], "the end effector at the goal configuration")
    for i, via in enumerate(() if goal is None else goal.vias):  # via and pick-and-place poses (goal_poses.py)
        check_poses(r, keep, via.pose[None], t[-1:], f"the pose of via {i}")
    return keep


#: How much a refinement round tightens the NLP's tilt per unit of the spline's excess beyond the
#: limit (:func:`tightened`): the excess between waypoints stays about the same from one solve to
#: the next, so twice of it leaves a margin of about one excess.
TIGHTEN_FACTOR = 2.0


def tightened(keep: KeepLevel, excess: float) -> KeepLevel:
    """``keep`` with ``max_tilt`` lowered by :data:`TIGHTEN_FACTOR` x ``excess`` (rad, the executed
    spline's worst tilt beyond the task's limit), at most halved: what the planner's refinement
    round gives the NLP when the tilt exceeds the limit between waypoints only."""
    return keep._replace(max_tilt=max(keep.max_tilt - TIGHTEN_FACTOR * max(excess, 0.0), 0.5 * keep.max_tilt))
