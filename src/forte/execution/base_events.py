"""Physical events of a base on the floor (:mod:`forte.execution.floor_base`): tip-over, slip, leaving the path.

Measured after every MuJoCo step (the contacts and forces of the step's start state, as
:func:`forte.execution.contact.touches`), for each support contact ``i`` (wheel or caster):

- its **normal force** ``f_i`` (N): the first component of ``mj_contactForce`` summed over the
  contacts of its geom with the ground; it is *loaded* while ``f_i >`` :attr:`BaseThresholds.lift_force`;
- **tip-over**: the loaded contacts no longer span an area (fewer than three, or all on one line:
  the largest triangle of loaded points under 1 cm^2) for :attr:`BaseThresholds.lift_time`: the base
  stands on an edge of its support polygon and rotates about it, which is the zero-moment point
  leaving the polygon (:mod:`forte.model.stability`); or the base's roll or pitch beyond
  :attr:`BaseThresholds.tip_angle`. One contact lifting alone (a four-legged base rocking onto
  three) is logged, not a failure;
- **slip** of a driven wheel (loaded): the velocity of the wheel's material point at the contact,
  ``v_c - (w_wheel r) x_b`` (``v_c`` the base's velocity at the contact point, ``x_b`` the base's
  forward axis), its norm above :attr:`BaseThresholds.slip` for :attr:`BaseThresholds.slip_time`;
  the lateral part is the wheel sliding sideways;
- **leaving the path**: the base origin farther than :attr:`BaseThresholds.path` from the planned
  one, or its yaw off by more than :attr:`BaseThresholds.path_yaw`.

``sim.csv`` gets ``fn_<contact>`` (N), ``roll``, ``pitch`` (rad), ``slip_<wheel>`` (m/s), ``v_lat``
(the base origin's velocity along its own y axis, m/s) and ``base_err`` (m); ``sim.json`` a ``base``
section (:meth:`BaseMonitor.summary`).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from itertools import combinations
from typing import Any

import mujoco
import numpy as np

from forte.execution.floor_base import WHEEL_RADIUS, roll_pitch
from forte.execution.judge import Judge
from forte.execution.model import SimModel
from forte.validation import FloatArray, as_positive

#: Seconds simulated after a tip-over before the run stops (the fall begins; MuJoCo then rolls
#: the robot over the floor).
AFTER_TIP = 0.25
#: Lift-offs listed in sim.json (all are counted).
MAX_LISTED = 20


@dataclass(frozen=True)
class BaseThresholds:
    """Failure criteria of a base on the floor (module docstring).

    Attributes:
        lift_force: A contact is off the floor below this normal force (N). 1 N.
        lift_time: How long the support must be an edge before it counts as tipping (s). 0.02 s.
        tip_angle: Roll or pitch of the base that is a tip-over whatever the contacts (rad). 0.1 rad.
        slip: Slip speed of a driven wheel that counts when sustained (m/s). 0.05 m/s.
        slip_time: How long the slip must last (s). 0.1 s.
        path: Distance of the base origin from the planned one (m). 0.1 m.
        path_yaw: Yaw error of the base (rad). 0.3 rad.
    """

    lift_force: float = 1.0
    lift_time: float = 0.02
    tip_angle: float = 0.1
    slip: float = 0.05
    slip_time: float = 0.1
    path: float = 0.1
    path_yaw: float = 0.3

    def __post_init__(self) -> None:
        for name, value in asdict(self).items():
            as_positive(value, f"base_thresholds.{name}")


class BaseMonitor:
    """Measures the support contacts, tilt, slip and path error of a floor base at every step and
    reports the first physical failure to the run's :class:`~forte.execution.judge.Judge`."""

    def __init__(self, sim: SimModel, th: BaseThresholds, record: list[int]) -> None:
        assert sim.floor is not None
        self.sim, self.floor, self.th, self.dt = sim, sim.floor, th, sim.timestep
        self.names = [c.name for c in self.floor.contacts]
        self.points = np.array([c.point for c in self.floor.contacts])
        self.wheels = [i for i, c in enumerate(self.floor.contacts) if c.wheel]
        self.slot = {int(g): i for i, g in enumerate(self.floor.geoms)}
        self.triples = np.array(list(combinations(range(len(self.names)), 3)), dtype=int).reshape(-1, 3)
        self.record = {k: r for r, k in enumerate(record)}
        n = len(record)
        self.rows = {"fn": np.zeros((n, len(self.names))), "tilt": np.zeros((n, 2)),
                     "slip": np.zeros((n, len(self.wheels))), "v_lat": np.zeros(n), "base_err": np.zeros(n)}
        self.edge_run = 0.0
        self.slip_run = np.zeros(len(self.wheels))
        self.unloaded_since: list[float | None] = [None] * len(self.names)
        self.lifts: list[dict[str, Any]] = []
        self.fn_min = np.full(len(self.names), np.inf)
        self.fn_max = np.zeros(len(self.names))
        self.peak = {"roll": 0.0, "pitch": 0.0, "slip": np.zeros(len(self.wheels)), "v_lat": 0.0, "base_err": 0.0,
                     "yaw_err": 0.0}
        self.fn = np.zeros(len(self.names))
        self.tipped_at: float | None = None

    def normal_forces(self) -> FloatArray:
        """Normal force (N) of each support contact in the step just taken."""
        m, d = self.sim.model, self.sim.data
        fn = np.zeros(len(self.names))
        wrench = np.zeros(6)
        for i in range(d.ncon):
            c = d.contact[i]
            slot = self.slot.get(int(c.geom1), self.slot.get(int(c.geom2)))
            if slot is not None:
                mujoco.mj_contactForce(m, d, i, wrench)
                fn[slot] += wrench[0]
        return fn

    def wheel_slip(self) -> FloatArray:
        """Slip velocity norm (m/s) of each driven wheel (module docstring)."""
        d, f = self.sim.data, self.floor
        R = np.zeros(9)
        mujoco.mju_quat2Mat(R, d.qpos[f.free_q + 3:f.free_q + 7])
        R = R.reshape(3, 3)
        v0, omega = d.qvel[f.free_v:f.free_v + 3], R @ d.qvel[f.free_v + 3:f.free_v + 6]
        out = np.zeros(len(self.wheels))
        for j, (i, dof) in enumerate(zip(self.wheels, f.wheel_dofs, strict=True)):
            r = R @ np.r_[self.points[i], 0.0]
            v = v0 + np.cross(omega, r) - d.qvel[dof] * WHEEL_RADIUS * R[:, 0]
            out[j] = float(np.linalg.norm(v[:2]))
        return out

    def step(self, k: int, q: FloatArray, dq: FloatArray, q_d: FloatArray, judge: Judge) -> bool:
        """Measure step ``k`` (state ``q, dq`` before it, reference ``q_d``) and judge it; whether the
        run should stop (:meth:`fallen`)."""
        t = k * self.dt
        fn = self.fn = self.normal_forces()
        self.fn_min, self.fn_max = np.minimum(self.fn_min, fn), np.maximum(self.fn_max, fn)
        loaded = fn > self.th.lift_force
        self._lift_offs(t, loaded)
        f = self.floor
        R = np.zeros(9)
        mujoco.mju_quat2Mat(R, self.sim.data.qpos[f.free_q + 3:f.free_q + 7])
        roll, pitch = roll_pitch(R.reshape(3, 3))
        slip = self.wheel_slip() if self.wheels else np.zeros(0)
        c, s = np.cos(q[2]), np.sin(q[2])
        v_lat = -s * dq[0] + c * dq[1]
        err = float(np.hypot(*(q_d[:2] - q[:2])))
        yaw_err = abs((q_d[2] - q[2] + np.pi) % (2 * np.pi) - np.pi)
        p = self.peak
        p["roll"], p["pitch"] = max(p["roll"], abs(roll)), max(p["pitch"], abs(pitch))
        p["v_lat"], p["base_err"], p["yaw_err"] = max(p["v_lat"], abs(v_lat)), max(p["base_err"], err), max(
            p["yaw_err"], yaw_err)
        p["slip"] = np.maximum(p["slip"], np.where(loaded[self.wheels], slip, 0.0))
        self._judge(t, loaded, roll, pitch, slip, err, yaw_err, judge)
        r = self.record.get(k)
        if r is not None:
            self.rows["fn"][r], self.rows["tilt"][r], self.rows["slip"][r] = fn, (roll, pitch), slip
            self.rows["v_lat"][r], self.rows["base_err"][r] = v_lat, err
        return self.fallen(t)

    def _lift_offs(self, t: float, loaded: FloatArray) -> None:
        """Log each contact that stays off the floor for ``lift_time`` (once per lift-off)."""
        for i, on in enumerate(loaded):
            since = self.unloaded_since[i]
            if on:
                self.unloaded_since[i] = None
            elif since is None:
                self.unloaded_since[i] = t
            elif t - since >= self.th.lift_time - 1e-9 and not any(
                    e["contact"] == self.names[i] and e["t"] == since for e in self.lifts):
                self.lifts.append({"contact": self.names[i], "t": since})

    def _judge(self, t: float, loaded: FloatArray, roll: float, pitch: float, slip: FloatArray, err: float,
               yaw_err: float, judge: Judge) -> None:
        th = self.th
        pts = self.points
        tri = self.triples[np.all(loaded[self.triples], axis=1)]
        a, b, c = pts[tri[:, 0]], pts[tri[:, 1]], pts[tri[:, 2]]
        area = 0.5 * np.abs((b - a)[:, 0] * (c - a)[:, 1] - (b - a)[:, 1] * (c - a)[:, 0])
        self.edge_run = 0.0 if area.size and area.max() > 1e-4 else self.edge_run + self.dt
        wheels_on = loaded[self.wheels] if self.wheels else np.zeros(0, dtype=bool)
        self.slip_run = np.where((slip > th.slip) & wheels_on, self.slip_run + self.dt, 0.0)
        tipping = self.edge_run >= th.lift_time - 1e-9 or max(abs(roll), abs(pitch)) > th.tip_angle
        if tipping and self.tipped_at is None:
            self.tipped_at = t
        if self.edge_run >= th.lift_time - 1e-9:
            off = [n for n, on in zip(self.names, loaded, strict=True) if not on]
            on = [n for n, on in zip(self.names, loaded, strict=True) if on]
            judge.fail(t, "tip-over", f"the base stands on {', '.join(on) or 'nothing'} only at t = {t:.3f} s "
                       f"({', '.join(off)} off the floor); roll {roll:.3f} rad, pitch {pitch:.3f} rad")
        elif max(abs(roll), abs(pitch)) > th.tip_angle:
            judge.fail(t, "tip-over", f"base roll {roll:.3f} rad, pitch {pitch:.3f} rad at t = {t:.3f} s "
                       f"(limit {th.tip_angle} rad)")
        elif np.any(self.slip_run >= th.slip_time - 1e-9):
            j = int(np.argmax(self.slip_run))
            judge.fail(t, "slip", f"{self.names[self.wheels[j]]} slips at {slip[j]:.3f} m/s for {th.slip_time} s "
                       f"(t = {t:.3f} s)")
        elif err > th.path or yaw_err > th.path_yaw:
            judge.fail(t, "off path", f"base {err:.3f} m and {yaw_err:.3f} rad off its planned pose at t = {t:.3f} s")

    def fallen(self, t: float) -> bool:
        """Whether the base tipped more than :data:`AFTER_TIP` s before ``t``: what follows is a
        robot lying on the floor, not the plan's execution, and the run stops."""
        return self.tipped_at is not None and t - self.tipped_at > AFTER_TIP

    def columns(self, rows: int) -> dict[str, FloatArray]:
        """The ``sim.csv`` columns of the first ``rows`` recorded steps (module docstring)."""
        out = {f"fn_{n}": self.rows["fn"][:rows, i] for i, n in enumerate(self.names)}
        out["roll"], out["pitch"] = self.rows["tilt"][:rows, 0], self.rows["tilt"][:rows, 1]
        out.update({f"slip_{self.names[i]}": self.rows["slip"][:rows, j] for j, i in enumerate(self.wheels)})
        out["v_lat"], out["base_err"] = self.rows["v_lat"][:rows], self.rows["base_err"][:rows]
        return out

    def summary(self) -> dict[str, Any]:
        """The ``base`` section of ``sim.json``."""
        p = self.peak
        return {
            "model": "floor", "drive": self.floor.drive,
            "contacts": [{"name": n, "point": self.points[i].tolist(), "wheel": i in self.wheels,
                          "min_normal_N": float(self.fn_min[i]), "max_normal_N": float(self.fn_max[i])}
                         for i, n in enumerate(self.names)],
            "tipped_at": self.tipped_at, "lift_offs": self.lifts[:MAX_LISTED], "lift_off_count": len(self.lifts),
            "max_roll_rad": p["roll"], "max_pitch_rad": p["pitch"],
            "max_slip_m_s": {self.names[i]: float(p["slip"][j]) for j, i in enumerate(self.wheels)},
            "max_lateral_speed_m_s": p["v_lat"], "max_path_error_m": p["base_err"], "max_yaw_error_rad": p["yaw_err"],
            "thresholds": asdict(self.th),
        }


__all__ = ["BaseMonitor", "BaseThresholds"]
