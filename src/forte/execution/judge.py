"""The verdict of a simulated execution: failure criteria, the per-step judge and the result.

The payload is welded to the end effector in the simulation (:mod:`forte.execution.model`), so
it can never fall off; a *payload drop* is judged from the motion instead: the end effector
sagging more than :attr:`Thresholds.drop_sag` below the plan, or tilting more than
:attr:`Thresholds.drop_tilt` away from the planned orientation, while a payload is carried.

A touch is a failure: any contact between the robot and the scene or the floor
(:mod:`forte.execution.contact`) fails the run with reason ``"contact"`` at its first time, and
every pair that touched is recorded (:attr:`Judge.contacts`: the robot's body, the world's body,
the first time, the peak normal force).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from forte.validation import FloatArray, as_positive


@dataclass(frozen=True)
class Thresholds:
    """Failure criteria of a simulated execution (the first one met gives the verdict).

    Attributes:
        drop_sag: Payload drop: the end effector is this far (m) *below* the planned height
            while a payload is carried (an object that is not lifted or slips out). 0.10 m.
        drop_tilt: Payload drop: the end-effector z axis tilts this far (rad) from the planned
            one while a payload is carried (the basket spills). 0.5 rad.
        sag: End-effector sag: vertical shortfall (m) that counts when sustained. 0.03 m.
        sag_time: How long (s) the sag must last. 0.2 s.
        saturation_time: Sustained torque saturation: one joint's command exceeds its limit for
            this long (s) without interruption. 0.25 s.
        max_ee_error: Tracking loss: end-effector position error norm (m) at any instant. 0.15 m.
    """

    drop_sag: float = 0.10
    drop_tilt: float = 0.5
    sag: float = 0.03
    sag_time: float = 0.2
    saturation_time: float = 0.25
    max_ee_error: float = 0.15

    def __post_init__(self) -> None:
        for name in ("drop_sag", "drop_tilt", "sag", "sag_time", "saturation_time", "max_ee_error"):
            as_positive(getattr(self, name), f"thresholds.{name}")


@dataclass
class SimResult:
    """Outcome of :func:`forte.execution.run.simulate_plan`.

    Attributes:
        success: No failure criterion was met.
        reason: ``None`` on success, else ``"payload drop"``, ``"end-effector sag"``,
            ``"torque saturation"``, ``"tracking loss"``, ``"contact"`` or ``"unstable"``.
        failure_time: Simulated time (s) at which the criterion was met (``None`` on success).
        detail: One human-readable sentence on the failure.
        log: Recorded columns (name -> array), also written to ``sim.csv``.
        summary: Scalar statistics (max errors, saturation fractions, wall time, ...).
    """

    success: bool
    reason: str | None
    failure_time: float | None
    detail: str
    log: dict[str, FloatArray]
    summary: dict[str, Any]

    def to_json(self) -> dict[str, Any]:
        return {
            "verdict": "success" if self.success else "failure",
            "reason": self.reason,
            "failure_time": self.failure_time,
            "detail": self.detail,
            **self.summary,
        }


class Judge:
    """Checks the :class:`Thresholds` at every control step and keeps the first failure.

    Args:
        thresholds: The failure criteria.
        dt: Control period (s), to time the sustained criteria.
        n_arm: Number of arm joints (saturation is timed per joint).
        payload: Whether a payload is carried (the payload-drop criteria apply only then).
    """

    def __init__(self, thresholds: Thresholds, dt: float, n_arm: int, payload: bool) -> None:
        self.th, self.dt, self.payload = thresholds, dt, payload
        self.sag_run = 0.0
        self.sat_run = np.zeros(n_arm)
        self.reason: str | None = None
        self.time: float | None = None
        self.detail = ""
        self.contacts: dict[tuple[str, str], dict[str, Any]] = {}

    def fail(self, t: float, reason: str, detail: str) -> None:
        """Record a failure at time ``t`` unless an earlier one was recorded."""
        if self.reason is None:
            self.reason, self.time, self.detail = reason, t, detail

    def touch(self, t: float, touches: Iterable[tuple[str, str, float]]) -> None:
        """Record the robot-versus-world contacts at time ``t``: ``(robot body, world body, normal
        force N)`` triples (:func:`forte.execution.contact.touches`); the first fails the run."""
        for robot, world, force in touches:
            pair = self.contacts.get((robot, world))
            if pair is None:
                self.contacts[(robot, world)] = {"robot": robot, "world": world, "first_time": t,
                                                 "first_force_N": force, "peak_force_N": force}
                self.fail(t, "contact", f"{robot} touched {world} at t = {t:.3f} s, normal force {force:.1f} N")
            else:
                pair["peak_force_N"] = max(pair["peak_force_N"], force)

    def contact_list(self) -> list[dict[str, Any]]:
        """Every pair that touched, in the order of their first contact."""
        return sorted(self.contacts.values(), key=lambda c: c["first_time"])

    def step(self, t: float, ee_err: FloatArray, tilt: float, saturated: FloatArray) -> None:
        """Judge one control step.

        Args:
            t: Simulated time (s).
            ee_err: End-effector position error ``p - p_d`` (m, world frame).
            tilt: Angle (rad) between the simulated and planned end-effector z axes.
            saturated: Per arm joint, whether the commanded torque exceeded its limit.
        """
        th = self.th
        sag = -ee_err[2]  # ee_err = p - p_d: negative z = below the plan
        self.sag_run = self.sag_run + self.dt if sag > th.sag else 0.0
        self.sat_run = np.where(saturated, self.sat_run + self.dt, 0.0)
        if self.payload and sag > th.drop_sag:
            self.fail(t, "payload drop", f"end effector {sag:.3f} m below the plan at t = {t:.3f} s")
        elif self.payload and tilt > th.drop_tilt:
            self.fail(t, "payload drop", f"end effector tilted {tilt:.2f} rad at t = {t:.3f} s")
        elif float(np.linalg.norm(ee_err)) > th.max_ee_error:
            self.fail(t, "tracking loss",
                      f"end-effector error {np.linalg.norm(ee_err):.3f} m at t = {t:.3f} s")
        elif self.sag_run >= th.sag_time - 1e-9:
            self.fail(t, "end-effector sag",
                      f"end effector more than {th.sag} m below the plan for {th.sag_time} s "
                      f"(t = {t:.3f} s)")
        elif np.any(self.sat_run >= th.saturation_time - 1e-9):
            j = int(np.argmax(self.sat_run))
            self.fail(t, "torque saturation",
                      f"joint {j + 1} saturated for {th.saturation_time} s (t = {t:.3f} s)")
