"""Paths of task files: the end-effector targets as functions of time, and their start and end rules.

Three kinds (``path.kind``): ``waypoints`` (timed positions joined by quintic blends; each may
carry an ``orientation``, joined by slerp with the same blend, :func:`slerp_path`),
``windowed-sine`` (the paper's Section 5.2 formula) and ``taught`` (timed whole-body
configurations: their forward kinematics joined by Cartesian quintic blends and slerp). A path
must start at the initial end-effector pose (:func:`starting_at`) and, for a plan that ends at
rest, holds its final pose over the last samples (:func:`ending_at_rest`). Every kind, goals
included, may keep a tool axis level (``path.keep_level``, :mod:`forte.planning.tasks.keep_level`).
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from dataclasses import replace

import numpy as np
import pinocchio as pin

from forte.force.taskforce import TaskForce
from forte.model.robot import MobileManipulator
from forte.model.trajectory import quintic_blend, quintic_path
from forte.planning.tasks.schema import Reader, check_joint_limits, rotation
from forte.validation import MAX_DURATION_S, MAX_WAYPOINTS, FloatArray

TargetsAt = Callable[[FloatArray], FloatArray]
ForceAt = Callable[[FloatArray], TaskForce]


def windowed_sine(t: FloatArray, duration: float, offset: FloatArray, amp: FloatArray, freq: FloatArray,
                   phase: FloatArray) -> FloatArray:
    """Paper Section 5.2: ``y(t) = w(t) (c + a * sin(2 pi f t + phi))``, ``w = 4 s (1 - s)``."""
    s = quintic_blend(np.clip(t / duration, 0, 1))
    w = 4 * s * (1 - s)
    return w[:, None] * (offset + amp * np.sin(2 * np.pi * freq * t[:, None] + phase))


def sine_parameters(r: Reader) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    return (r.vector("offset", 3, [0, 0, 0]), r.vector("amplitude", 3), r.vector("frequency", 3),
            r.vector("phase", 3, [0, 0, 0]))


def _samples(r: Reader, t0: float, t1: float, waypoints: int | None) -> FloatArray:
    if waypoints is not None:
        n = waypoints
    elif r.has("samples"):
        n = r.integer("samples", minimum=2, maximum=MAX_WAYPOINTS)
    elif r.has("rate"):
        rate = r.number("rate", positive=True)
        samples = (t1 - t0) * rate + 1  # durations are bounded: finite
        if samples > MAX_WAYPOINTS + 0.5:
            raise r.error("rate", f"gives {samples:.0f} waypoints over {t1 - t0:g} s; expected at most "
                          f"{MAX_WAYPOINTS} (forte's documented bound)")
        n = int(round(samples))
        if n < 2:
            raise r.error("rate", f"gives {n} waypoint over {t1 - t0} s; expected at least 2")
    else:
        n = 50
    return np.linspace(t0, t1, n)


def _time(w: Reader) -> float:
    """An item's ``t`` within forte's documented bound on durations."""
    t = w.number("t")
    if abs(t) > MAX_DURATION_S:
        raise w.error("t", f"expected a time within +-{MAX_DURATION_S:g} s (forte's documented bound), got {t:g}")
    return t


def taught_knots(r: Reader, robot: MobileManipulator) -> tuple[FloatArray, FloatArray]:
    """``(times, configurations)`` of ``path.configurations`` (``[{t, q}, ...]``, times increasing)."""
    items = r.get("configurations")
    if not isinstance(items, list) or len(items) < 2:
        raise r.error("configurations", "expected a list of at least 2 taught configurations {t, q}")
    times, qs = [], []
    for i, item in enumerate(items):
        w = Reader(item, r.path, f"{r.key('configurations')}[{i}].")
        w.unknown({"t", "q"})
        times.append(_time(w))
        q = w.vector("q", robot.nq)
        check_joint_limits(w, "q", robot, q)
        qs.append(q)
    kt = np.asarray(times)
    bad = np.flatnonzero(np.diff(kt) <= 0)
    if bad.size:
        raise r.error(f"configurations[{bad[0] + 1}].t", f"times must increase, got {kt[bad[0]]} then {kt[bad[0] + 1]}")
    return kt, np.asarray(qs)


def slerp_path(knot_times: FloatArray, rotations: FloatArray, ts: FloatArray) -> FloatArray:
    """Rotations (K x 3 x 3) at ``ts`` through ``rotations`` (one per knot) by slerp with the
    positions' rest-to-rest quintic blend ``s`` per segment:

        ``R(t) = R_i exp(s(t) log(R_i^T R_{i+1}))``,  ``s = blend((t - t_i) / (t_{i+1} - t_i))``,

    the shorter turn about one fixed axis, at rest at every knot (``log`` and ``exp`` on SO(3):
    Pinocchio's ``log3``, ``exp3``)."""
    ts = np.asarray(ts, dtype=float)
    seg = np.clip(np.searchsorted(knot_times, ts, side="right") - 1, 0, len(knot_times) - 2)
    s = quintic_blend(np.clip((ts - knot_times[seg]) / (knot_times[seg + 1] - knot_times[seg]), 0.0, 1.0))
    out = np.empty((len(ts), 3, 3))
    for k, (i, sk) in enumerate(zip(seg, s, strict=True)):
        Ra, Rb = rotations[i], rotations[i + 1]
        out[k] = Ra @ pin.exp3(sk * pin.log3(Ra.T @ Rb))
    return out


def taught_targets(robot: MobileManipulator, knot_times: FloatArray, knots: FloatArray) -> TargetsAt:
    """End-effector poses through the forward kinematics of taught configurations: positions by
    rest-to-rest quintic blends, orientations by slerp with the same blend, per segment."""
    poses = np.array([robot.ee_pose(q) for q in knots])

    def targets_at(ts: FloatArray) -> FloatArray:
        ts = np.asarray(ts, dtype=float)
        out = np.repeat(np.eye(4)[None], len(ts), axis=0)
        out[:, :3, 3] = quintic_path(knot_times, poses[:, :3, 3], ts)
        out[:, :3, :3] = slerp_path(knot_times, poses[:, :3, :3], ts)
        return out
    return targets_at


def waypoint_knots(r: Reader, T0: FloatArray, R: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray | None]:
    """``path.waypoints`` (``[{t, position, orientation}, ...]``, times increasing): their times,
    positions (world; relative to ``T0``'s with ``relative: true``) and rotations, ``None`` when no
    waypoint has an orientation (the path holds ``R``). A waypoint without one keeps the one before
    it (the first: ``R``, the path's ``orientation`` or the start's)."""
    pts = r.get("waypoints")
    if not isinstance(pts, list) or len(pts) < 2:
        raise r.error("waypoints", "expected a list of at least 2 waypoints {t, position}")
    relative = r.get("relative", False)
    if not isinstance(relative, bool):
        raise r.error("relative", f"expected true or false, got {relative!r}")
    times, positions, rotations, turned = [], [], [], False
    for i, item in enumerate(pts):
        w = Reader(item, r.path, f"{r.key('waypoints')}[{i}].")
        w.unknown({"t", "position", "orientation"})
        times.append(_time(w))
        p = w.vector("position", 3)
        positions.append(T0[:3, 3] + p if relative else p)
        turned = turned or w.has("orientation")
        rotations.append(rotation(w, "orientation", rotations[-1] if rotations else R))
    kt = np.asarray(times)
    bad = np.flatnonzero(np.diff(kt) <= 0)
    if bad.size:
        raise r.error(f"waypoints[{bad[0] + 1}].t", f"times must increase, got {kt[bad[0]]} then {kt[bad[0] + 1]}")
    return kt, np.asarray(positions), np.asarray(rotations) if turned else None


#: The fields of every path, and those of each kind.
PATH_FIELDS = frozenset({"kind", "samples", "rate", "orientation", "keep_level"})
PATH_KIND_FIELDS = {"waypoints": frozenset({"waypoints", "relative"}),
                    "windowed-sine": frozenset({"duration", "offset", "amplitude", "frequency", "phase"}),
                    "taught": frozenset({"configurations"})}


def build_path(reader: Reader, T0: FloatArray, waypoints: int | None,
          robot: MobileManipulator | None = None) -> tuple[FloatArray, TargetsAt]:
    if not reader.has("path"):
        raise reader.error("path", "required for mode 'trajectory'")
    r = reader.sub("path")
    kind = r.get("kind", "waypoints")
    if kind not in PATH_KIND_FIELDS:
        raise r.error("kind", f"expected 'waypoints', 'windowed-sine', 'taught' or 'goal', got {kind!r}")
    r.unknown(PATH_FIELDS | PATH_KIND_FIELDS[kind])  # another kind's field is refused, not ignored
    R = rotation(r, "orientation", T0[:3, :3])
    if kind == "taught" and robot is not None:
        kt, kq = taught_knots(r, robot)
        return _samples(r, kt[0], kt[-1], waypoints), taught_targets(robot, kt, kq)
    rotations = None
    if kind == "waypoints":
        times_arr, knots, rotations = waypoint_knots(r, T0, R)
        t = _samples(r, times_arr[0], times_arr[-1], waypoints)

        def position_at(ts: FloatArray) -> FloatArray:
            return quintic_path(times_arr, knots, ts)
    elif kind == "windowed-sine":
        duration = r.number("duration", positive=True, maximum=MAX_DURATION_S, unit=" s")
        t = _samples(r, 0.0, duration, waypoints)
        sine = sine_parameters(r)

        def position_at(ts: FloatArray) -> FloatArray:
            return T0[:3, 3] + windowed_sine(ts, duration, *sine)
    else:
        raise r.error("kind", f"expected 'waypoints', 'windowed-sine', 'taught' or 'goal', got {kind!r}")

    def targets_at(ts: FloatArray) -> FloatArray:
        targets = np.repeat(np.eye(4)[None], len(ts), axis=0)
        targets[:, :3, :3] = R if rotations is None else slerp_path(times_arr, rotations, ts)
        targets[:, :3, 3] = position_at(ts)
        return targets
    return t, targets_at


#: A path may start this close to the initial end-effector pose (m, rad); it is snapped to it.
START_TOLERANCE = (1e-3, 1e-3)


def starting_at(reader: Reader, first: FloatArray, T0: FloatArray, targets_at: TargetsAt) -> TargetsAt:
    """The path, checked to start at the initial end-effector pose ``T0`` (snapped within 1 mm and
    1 mrad, with a note); otherwise one error that says what differs, at full precision."""
    gap = float(np.linalg.norm(first[:3, 3] - T0[:3, 3]))
    turn = float(np.linalg.norm(pin.log3(T0[:3, :3].T @ first[:3, :3])))
    if gap <= 1e-9 and turn <= 1e-9:
        return targets_at
    if gap <= START_TOLERANCE[0] and turn <= START_TOLERANCE[1]:
        warnings.warn(f"{reader.path or '<task>'}: path: starts {gap * 1e3:.3g} mm and {turn * 1e3:.3g} mrad from "
                      "the end-effector pose of initial_configuration; snapped to it", stacklevel=2)

        def snapped(ts: FloatArray) -> FloatArray:
            out = targets_at(ts)
            out[0] = T0
            return out
        return snapped
    if gap > START_TOLERANCE[0]:
        raise reader.error("path", f"starts {gap!r} m from the end-effector position of initial_configuration, "
                           f"{T0[:3, 3].tolist()!r}; start there, or give positions relative to it "
                           "('relative: true')")
    path = reader.get("path") if isinstance(reader.get("path"), dict) else {}
    first = path.get("waypoints")[0] if isinstance(path.get("waypoints"), list) and path["waypoints"] else None
    field = "path.waypoints[0].orientation" if isinstance(first, dict) and first.get("orientation") is not None \
        else "path.orientation"
    orientation = first.get("orientation") if field != "path.orientation" else path.get("orientation")
    rpy = orientation.get("rpy") if isinstance(orientation, dict) else None
    hint = ""
    if isinstance(rpy, list) and any(isinstance(v, int | float) and abs(v) > 2 * np.pi for v in rpy):
        hint = "; orientation.rpy is in radians and these values look like degrees"
    raise reader.error(field, f"differs by {turn!r} rad from the end-effector orientation of "
                       f"initial_configuration (rpy {pin.rpy.matrixToRpy(T0[:3, :3]).tolist()!r} rad){hint}")


class HeldPath:
    """The path of a plan that ends at rest: it holds its final pose over the last two samples.

    A plan that ends at rest on the paper's backward differences has ``q_N = q_{N-1} = q_{N-2}``
    (``v_N = 0`` and ``a_N = 0``), so its three last targets must be one pose. A path that blends
    into its last pose (the quintic blends of the taught and waypoint paths) may still be moving at
    ``t_{N-2}``: the authors' lift on its 41 samples is 6.2 mm short of its final pose there. The
    targets are the path up to ``t_{N-2}`` and its final pose (at its end ``t_e``) from then on:

        ``T(t) = path(t)`` for ``t < t_{N-2}``, ``T(t) = path(t_e)`` from ``t_{N-2}`` on,

    at the samples exactly the held targets that keep the optimizer's pose equalities exact, and
    between them what the verdict's tracking judges the executed motion against, so the planner and
    the verdict agree on the path, the final hold included. :func:`ending_at_rest` keeps what the
    hold cuts within :data:`HOLD_TOLERANCE`, moving the two hold samples after the path's end when it
    would cut more (then ``t_e <= t_{N-2}``: nothing is cut). :meth:`on` moves the hold to another
    grid (a resampled task).
    """

    def __init__(self, path: TargetsAt, t: FloatArray, end: float | None = None) -> None:
        self.path = path
        self.t = np.asarray(t, dtype=float)
        self.end = float(self.t[-1] if end is None else end)

    def on(self, t: FloatArray) -> HeldPath:
        """The same path holding its final pose on the grid ``t``."""
        return HeldPath(self.path, t, self.end)

    def __call__(self, ts: FloatArray) -> FloatArray:
        times = np.minimum(np.array(ts, dtype=float), self.end)
        if self.t.size >= 3:
            times[times >= self.t[-3]] = self.end
        return self.path(times)


#: How much of the path (m, rad) a hold over the last two samples may cut before the hold samples
#: move after the path's end (:func:`ending_at_rest`): the verdict's tracking tolerances
#: (:data:`forte.planning.verdict.requirements.TRACKING_POSITION_TOL`, ``TRACKING_ORIENTATION_TOL``; a test
#: checks they agree). The paper's lift on its 41 samples cuts 6.2 mm and keeps its grid.
HOLD_TOLERANCE = (0.01, 0.05)


def hold_cut(path: TargetsAt, t: FloatArray) -> tuple[float, float]:
    """How far (m, rad) the path still is from its final pose at ``t_{N-2}``: what a hold over the
    last two samples of ``t`` cuts (a path that comes to rest monotonically in its last segment)."""
    if len(t) < 3:
        return 0.0, 0.0
    at_hold, final = path(np.array([t[-3], t[-1]]))
    gap = float(np.linalg.norm(at_hold[:3, 3] - final[:3, 3]))
    return gap, float(np.linalg.norm(pin.log3(final[:3, :3].T @ at_hold[:3, :3])))


def ending_at_rest(path: TargetsAt, t: FloatArray) -> tuple[FloatArray, HeldPath]:
    """The grid and the path of a plan that ends at rest (:class:`HeldPath`).

    The hold takes the last two samples of ``t`` where it cuts at most :data:`HOLD_TOLERANCE` of the
    path; otherwise the same number of samples is spread over the path (``N - 2`` equal steps
    ``h`` up to its end) and two more hold its final pose, ``h`` and ``2 h`` after the end: the
    path and its timing are kept exactly and the plan ends ``2 h`` later, at rest.
    """
    t = np.asarray(t, dtype=float)
    if len(t) < 4:
        return t, HeldPath(path, t)
    cut = hold_cut(path, t)
    if cut[0] <= HOLD_TOLERANCE[0] and cut[1] <= HOLD_TOLERANCE[1]:
        return t, HeldPath(path, t)
    end = float(t[-1])
    on_path = np.linspace(float(t[0]), end, len(t) - 2)
    h = float(on_path[1] - on_path[0])
    grid = np.r_[on_path, end + h, end + 2 * h]
    return grid, HeldPath(path, grid, end)


def force_with_hold(force_at: ForceAt | None, path: HeldPath, t: FloatArray) -> ForceAt | None:
    """``force_at`` on the grid ``t`` of ``path``: where the grid's hold samples lie after the path's
    end (:func:`ending_at_rest`), the force holds its value at the end over them."""
    if force_at is None or t[-1] <= path.end:
        return force_at
    end = path.end

    def at(ts: FloatArray) -> TaskForce:
        ts = np.asarray(ts, dtype=float)
        on_path = ts[ts < end]
        force = force_at(np.r_[on_path, end])
        rows = np.minimum(np.arange(ts.size), on_path.size)  # every time from the end on: the end's row
        m = None if force.m is None else force.m[rows]
        return replace(force, t=ts, f=force.f[rows], r=force.r[rows], m=m)
    return at
