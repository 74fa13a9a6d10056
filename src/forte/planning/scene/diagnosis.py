"""Why a solve failed: the rows the solver's last iterate breaks most, named by what they stand for.

When IPOPT stops without a solution (``Infeasible_Problem_Detected``, an iteration limit), its last
iterate ``x`` still says which constraints could not be met together. The rows of the NLP
(:mod:`forte.planning.nlp.optimizer`) are, in order: the end-effector pose equalities (6 per posed
waypoint: position error in m, then ``vee(R_d^T R - R^T R_d) / 2``), the kinematic rows, the
lifting rows, the clearance rows, the base's lateral rows, the ``keep_level`` rows. Each row's
violation is

    v_i = max(lb_i - g_i(x), g_i(x) - ub_i, 0),

recomputed from ``x`` (so it reads the same whichever solver ran). A clearance row stands for one
pair (:attr:`forte.planning.nlp.collision_slots.FrameSlots.pairs`: a robot primitive and a scene body,
or a pair of the robot's own parts) at one waypoint: slot ``j`` of waypoint ``k`` writes row ``j``,
the clearance at the midpoint of the chord from waypoint ``k - 1`` to ``k`` less half the chord,
:mod:`forte.planning.nlp.collision_kernels`. So ``v_i`` of a clearance row is how far (m) the part is
inside the clearance it must keep from that body.

**The rule** (measured on the table-to-shelf task of issue 36: the middle table's rows carry the
whole violation, 0.027 m at the hand, with the pose rows next to it missed by 7 mm as the solver
trades one for the other; without the middle table the same task solves): when a clearance row is
violated by more than the solver's accepted violation, the body whose rows carry the largest
violation is *in the way*; otherwise the worst pose row names the waypoint whose pose could not be
reached. The multipliers are not used: IPOPT caps them at the restoration phase's bound, so they
tie (1000 on both the table's rows and the pose rows of the repro).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np

from forte.model.body_spheres import robot_primitives
from forte.model.scene import FLOOR
from forte.planning.nlp.optimizer import SolverResult, TrajectoryOptimizer
from forte.planning.nlp.solvers.result import accepted_violation
from forte.planning.tasks.terms_section import term_values


class FailedRows(NamedTuple):
    """The constraint the last iterate of a failed solve breaks most.

    Attributes:
        kind: ``clearance`` (a body is in the way), ``keep_level`` (the tool axis tilted beyond
            ``path.keep_level``; ``short`` in degrees) or ``pose`` (the end-effector pose).
        body: the scene body (or ``floor``, or ``self: <part>`` for the robot's own part) whose
            clearance rows are violated most; ``None`` for ``pose``.
        part: the robot's part (its primitive's piece) on the worst row; ``None`` for ``pose``.
        short: the worst row's violation (m for clearance; the pose residual's norm for pose).
        waypoint, t: where (the waypoint index and its time, s).
        pose_miss: the largest pose-row violation anywhere (what the solver gave up on the path).
    """

    kind: str
    body: str | None
    part: str | None
    short: float
    waypoint: int
    t: float
    pose_miss: float

    def sentence(self) -> str:
        """One clause for the verdict line, e.g. ``in the way: mid_table (panda_hand 0.027 m inside
        the clearance at t = 7.75 s, waypoint 31, at the solver's last iterate)``."""
        where = f"at t = {self.t:.3g} s, waypoint {self.waypoint}, at the solver's last iterate"
        if self.kind == "clearance":
            return f"in the way: {self.body} ({self.part} {self.short:.3g} m inside the clearance {where})"
        if self.kind == "keep_level":
            return f"tilted: the end effector {self.short:.3g} deg beyond keep_level's max_tilt_deg ({where})"
        return f"unreachable: the end-effector pose (missed by {self.short:.3g} {where})"

    def to_json(self) -> dict[str, Any]:
        return dict(self._asdict()) | {"sentence": self.sentence()}


def _clearance_rows(opt: TrajectoryOptimizer, body_names: list[str]) -> list[tuple[int, str, str, int]]:
    """Per clearance row of ``opt``, in the NLP's order: ``(row offset, body, part, waypoint)``."""
    primitives = robot_primitives(opt.robot)
    out = []
    for frame in opt.slots.frames if opt.slots else ():
        for idx in np.flatnonzero(frame.keep.ravel()):
            k, slot = divmod(int(idx), frame.slots)  # the row of the chord from waypoint k - 1 to k
            p, m = frame.pairs.get((k, slot), (-1, 0))
            body = body_names[m] if m >= 0 else f"self: {primitives[-1 - m].piece}"
            out.append((len(out), body, primitives[p].piece if p >= 0 else "", k))
    return out


def failed_rows(opt: TrajectoryOptimizer, sol: SolverResult, task: Any, force: Any) -> FailedRows | None:
    """The constraint the last iterate ``sol.q`` of ``opt`` breaks most (see the module's rule), or
    ``None`` when no row is violated beyond the accepted violation (e.g. an iteration limit on a
    feasible iterate)."""
    p = opt.parameters(task.t, task.targets, force.f, force.r, getattr(opt, "_nominal", None),
                       term_values(opt.method_spec, force, task.terms), task.start_motion)
    lbx, ubx, lbg, ubg = opt.bounds(task.t, task.q_init, task.start_motion)
    g = np.array(opt._g(opt.full_x(sol.q), p)).ravel()
    excess = np.maximum(np.maximum(lbg - g, g - ubg), 0.0)
    tol = accepted_violation(opt.options)
    pose = excess[: 6 * opt._pose_steps.size].reshape(-1, 6)
    pose_norm = np.linalg.norm(pose, axis=1) if pose.size else np.zeros(0)
    pose_miss = float(pose_norm.max(initial=0.0))
    first = g.size - opt._clear_index.size - opt._lateral - opt._keep_steps.size
    clear = excess[first:first + opt._clear_index.size]
    names = list(task.scene.names) + ([FLOOR] if task.scene.floor is not None else [])
    rows = _clearance_rows(opt, names)
    if clear.size and clear.max() > tol:
        worst: dict[str, tuple[float, str, int]] = {}
        for i, body, part, k in rows:
            if clear[i] > worst.get(body, (0.0, "", 0))[0]:
                worst[body] = (float(clear[i]), part, k)
        body = max(worst, key=lambda b: worst[b][0])
        short, part, k = worst[body]
        return FailedRows("clearance", body, part, short, k, float(task.t[k]), pose_miss)
    keep = excess[g.size - opt._keep_steps.size:] if opt._keep_steps.size else np.zeros(0)
    if keep.size and keep.max() > tol:  # rows w . R a >= cos(max_tilt): the excess as an angle
        j = int(np.argmax(keep))
        k, limit = int(opt._keep_steps[j]), opt.keep_level.max_tilt
        beyond = np.degrees(np.arccos(np.clip(g[g.size - keep.size + j], -1.0, 1.0)) - limit)
        return FailedRows("keep_level", None, None, float(beyond), k, float(task.t[k]), pose_miss)
    if pose_miss > tol:
        j = int(np.argmax(pose_norm))
        k = int(opt._pose_steps[j])
        return FailedRows("pose", None, None, float(pose_norm[j]), k, float(task.t[k]), pose_miss)
    return None
