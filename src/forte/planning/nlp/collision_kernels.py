"""Clearance rows of the NLP: a compiled kernel per robot frame evaluates ``K`` robot-versus-scene pairs.

A *slot* is one pair: a robot primitive ``a`` (:mod:`forte.model.body_spheres`: a sphere, or a
vertical capsule on the base) against a scene body's proxy ``b`` (a rounded box,
:func:`forte.model.scene.proxy_distance`). Each frame of the robot (the base's, each arm
joint's) has its own kernel with ``K_f`` slots, so a slot's point moves with one frame (a slot
that could pick its frame costs ~6x more Hessian instructions, and the base's kernel needs no
arm kinematics). Which pairs fill the slots is task data (NLP parameters,
:mod:`forte.planning.nlp.collision_slots`), so one compiled kernel serves every scene with at most
``K_f`` close pairs on frame ``f`` per waypoint; ``K_f`` is rounded up to :data:`SLOT_BUCKETS`.

For waypoint ``k`` a slot gives one row, at the midpoint of the straight chord from waypoint
``k - 1`` to ``k``:

    D(x) = sdf_b(x) - r_a,      D((x_a(q_{k-1}) + x_a(q_k)) / 2) >= m + |Δ_k| / 2,

``m`` the clearance and ``Δ_k`` the change of ``a``'s position relative to ``b`` between the two
waypoints: every point of the chord is within ``|Δ_k| / 2`` of its midpoint, and a signed
distance is 1-Lipschitz, so the whole chord, both waypoints included, keeps the clearance ``m``
(the executed spline bends away from the chord by a little; the exact check measures it). One
row per slot, not one per end (``D(q_k) >= c`` and ``D(q_{k-1}) >= c``, which keep the chord
too): half the inequality rows in IPOPT's KKT system, and never tighter than the two ends'
rows for a distance that is linear along the chord (a primitive moving straight at a wall).

Guards (the exact distances are what the verdict reports): a norm is ``sqrt(|v|^2 + eps^2) -
eps`` with ``eps`` = 1e-9 m, so its derivative exists at 0; the value moves by < 1e-9 m.
"""

from __future__ import annotations

import hashlib
import shutil
from pathlib import Path
from typing import Any, NamedTuple

import casadi as ca
import numpy as np

from forte import __version__, progress
from forte.model.description import N_BASE
from forte.model.twin import CasadiTwin, rot_z
from forte.planning.nlp.compile_target import signature
from forte.settings import SolverOptions

EPS = 1e-9

#: Numbers of slots per frame a kernel is compiled for (the smallest that holds a task's pairs).
SLOT_BUCKETS = (1, 2, 4, 8, 16, 32)

KERNEL_NAMES = ("clear_rows", "clear_jac", "clear_hess")


#: One slot's parameters: ``a``'s centre in its frame's axes, its vertical half length and radius,
#: then the body's proxy (centre, yaw as cos and sin, half extents, rho, sigma), the clearance,
#: and 1 for a slot in use (0: an empty slot, its rows are 1 >= 0).
SLOT_FIELDS: dict[str, tuple[int, int]] = {}
_offset = 0
for _name, _size in (("centre_a", 3), ("half_a", 1), ("radius_a", 1), ("origin", 3), ("yaw", 2), ("half", 3),
                     ("rho", 1), ("sigma", 1), ("margin", 1), ("active", 1)):
    SLOT_FIELDS[_name] = (_offset, _size)
    _offset += _size
#: Length of one slot's parameter vector.
SLOT_SIZE = _offset

#: A self-collision slot's parameters: primitive ``a``'s centre (its frame's axes) and radius,
#: primitive ``b``'s centre (its frame's axes), vertical half length and radius, the clearance
#: and the in-use flag.
SELF_FIELDS: dict[str, tuple[int, int]] = {}
_offset = 0
for _name, _size in (("centre_a", 3), ("radius_a", 1), ("centre_b", 3), ("half_b", 1), ("radius_b", 1),
                     ("margin", 1), ("active", 1)):
    SELF_FIELDS[_name] = (_offset, _size)
    _offset += _size
SELF_SIZE = _offset


def _norm(v: Any) -> Any:
    return ca.sqrt(ca.sumsqr(v) + EPS**2) - EPS


def rounded_box_distance(p: Any, half: Any, rho: Any, sigma: Any) -> Any:
    """CasADi twin of :func:`forte.model.scene.proxy_distance` for a point ``p`` in the proxy's axes."""
    q = ca.fabs(p[:2]) - half[:2]
    a = _norm(ca.fmax(q, 0)) + ca.fmin(ca.fmax(q[0], q[1]), 0) - rho
    b = ca.fabs(p[2]) - half[2]
    ab = ca.vertcat(a, b)
    return _norm(ca.fmax(ab, 0)) + ca.fmin(ca.fmax(a, b), 0) - sigma


def world_frames(twin: CasadiTwin, q: Any) -> list[tuple[Any, Any]]:
    """World rotation and position of the base frame and of every arm joint frame at ``q``."""
    Rb = rot_z(q[2])
    pb = ca.vertcat(q[0], q[1], 0)
    return [(Rb, pb)] + [(Rb @ R, Rb @ p + pb) for R, p in twin._arm_poses(q[N_BASE:])]


def slot_offset(frame: tuple[Any, Any], s: dict[str, Any]) -> Any:
    """``x_a - x_b`` of one slot whose primitive hangs on ``frame`` (world R, p at ``q``): from
    the body's origin to the primitive's centre."""
    R, p = frame
    return R @ s["centre_a"] + p - s["origin"]


def slot_distance(d: Any, s: dict[str, Any]) -> Any:
    """``D`` of one slot at the offset ``d = x_a - x_b`` (:func:`slot_offset`)."""
    c, sn = s["yaw"][0], s["yaw"][1]
    local_xy = ca.vertcat(c * d[0] + sn * d[1], -sn * d[0] + c * d[1])
    dz = d[2] - ca.fmin(ca.fmax(d[2], -s["half_a"]), s["half_a"])  # nearest point of a's vertical segment
    return rounded_box_distance(ca.vertcat(local_xy, dz), s["half"], s["rho"], s["sigma"]) - s["radius_a"]


def self_offset(frame_a: tuple[Any, Any], frame_b: tuple[Any, Any], s: dict[str, Any]) -> Any:
    """``x_a - x_b`` of a self-collision slot at the frames of ``q``."""
    return frame_a[0] @ s["centre_a"] + frame_a[1] - (frame_b[0] @ s["centre_b"] + frame_b[1])


def self_distance(d: Any, s: dict[str, Any]) -> Any:
    """``D`` of a self-collision slot at the offset ``d`` (:func:`self_offset`): primitive ``a``
    (a sphere) against ``b`` (a sphere, or a vertical capsule on the base)."""
    dz = d[2] - ca.fmin(ca.fmax(d[2], -s["half_b"]), s["half_b"])
    return _norm(ca.vertcat(d[0], d[1], dz)) - s["radius_a"] - s["radius_b"]


def build_collision_kernels(robot: Any, frame: int, slots: int, other: int | None = None) -> dict[str, ca.Function]:
    """SX kernels of ``slots`` slots whose primitives hang on ``frame`` (0: the base's, ``j + 1``:
    arm joint ``j``'s), on the stage window ``z = [q_{k-2}; q_{k-1}; q_k]``: against scene bodies,
    or with ``other`` against the robot's own primitives on frame ``other`` (self-collision)."""
    twin, nq = CasadiTwin(robot), robot.nq
    z = ca.SX.sym("z", 3 * nq)
    frames_now, frames_before = world_frames(twin, z[2 * nq:]), world_frames(twin, z[nq:2 * nq])
    fields, size = (SLOT_FIELDS, SLOT_SIZE) if other is None else (SELF_FIELDS, SELF_SIZE)
    P = ca.SX.sym("slots", size * slots)
    rows = []
    for i in range(slots):
        v = P[i * size:(i + 1) * size]
        s = {name: v[o:o + n] for name, (o, n) in fields.items()}
        if other is None:
            d_now, d_before = slot_offset(frames_now[frame], s), slot_offset(frames_before[frame], s)
            middle = slot_distance(0.5 * (d_now + d_before), s)
        else:
            d_now = self_offset(frames_now[frame], frames_now[other], s)
            d_before = self_offset(frames_before[frame], frames_before[other], s)
            middle = self_distance(0.5 * (d_now + d_before), s)
        need = s["margin"] + 0.5 * _norm(d_now - d_before)
        rows.append(s["active"] * (middle - need) + 1 - s["active"])
    g = ca.vertcat(*rows)
    lam = ca.SX.sym("lam", slots)
    H, _ = ca.hessian(ca.dot(lam, g), z)
    return {
        "clear_rows": ca.Function("clear_rows", [z, P], [g]),
        "clear_jac": ca.Function("clear_jac", [z, P], [ca.densify(ca.jacobian(g, z))]),
        "clear_hess": ca.Function("clear_hess", [z, P, lam], [ca.densify(H)]),
    }


class CollisionKernels(NamedTuple):
    """One frame's clearance rows (1 per slot), their Jacobian and Lagrangian Hessian in ``z``
    (``other``: the second frame of self-collision slots, ``None`` for scene slots)."""

    rows: ca.Function
    jac: ca.Function
    hess: ca.Function
    frame: int
    slots: int
    other: int | None = None

    @property
    def name(self) -> str:
        return f"clear{self.frame}" if self.other is None else f"self{self.frame}_{self.other}"

    @property
    def size(self) -> int:
        """Parameters per waypoint."""
        return self.slots * (SLOT_SIZE if self.other is None else SELF_SIZE)


def load_collision_kernels(robot: Any, frame: int, slots: int, options: SolverOptions,
                           other: int | None = None) -> CollisionKernels:
    """The kernels of ``slots`` slots on ``frame`` (against ``other``'s primitives when given),
    compiled to C and cached like the stage kernels."""
    from forte.planning.nlp import kernels as stage

    compiler = shutil.which("gcc") or shutil.which("cc")
    if options.codegen and compiler:
        key = hashlib.sha256(repr((__version__, robot.fingerprint, frame, slots, other, ca.__version__,
                                   Path(__file__).read_bytes(), stage._source_digest(),
                                   signature(compiler))).encode()).hexdigest()[:20]
        tag = f"f{frame}" if other is None else f"f{frame}-{other}"
        lib = stage.cache_root(options) / f"clearance_{tag}_{slots}_{key}.so"
        fns = stage._load_verified(lib, names=KERNEL_NAMES)
        if fns is None:
            try:
                with progress.step(f"compiling clearance kernels to C (frame {frame}, {slots} pairs, once)", 3.0):
                    stage._compile(build_collision_kernels(robot, frame, slots, other), lib, compiler)
                fns = stage._load_verified(lib, quiet=False, names=KERNEL_NAMES)
            except OSError as exc:
                stage.notice(f"cannot build the clearance kernels in {lib.parent} ({exc}); using CasADi's "
                             "virtual machine (slower, same results)")
        if fns is not None:
            return CollisionKernels(*(fns[n] for n in KERNEL_NAMES), frame, slots, other)
    fns = build_collision_kernels(robot, frame, slots, other)
    return CollisionKernels(*(fns[n] for n in KERNEL_NAMES), frame, slots, other)


def bucket(pairs: int) -> int:
    """The smallest compiled slot count that holds ``pairs`` pairs."""
    for size in SLOT_BUCKETS:
        if pairs <= size:
            return size
    return int(2 ** np.ceil(np.log2(pairs)))
