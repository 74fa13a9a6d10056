"""Pick and place in ``forte simulate``: the payload attaches at the grasp.

A pick-and-place plan (``path.goals``, :mod:`forte.planning.tasks.goal_poses`) records the time of
its grasp in plan.json (``solver.goal.grasp_time_s``); its force is the robot's own tool load
before it. The simulation builds the carried body as for any payload (the payload with the tool
load, :func:`~forte.execution.bodies.carried_body`), scales its mass and inertia down to the tool
load's share ``m_tool / (m + m_tool)`` (zero without a tool) before the run, and restores them once
the simulated time reaches the grasp. MuJoCo's dynamics read ``body_mass`` and ``body_inertia`` at
every step; :func:`mujoco.mj_setConst` recomputes the constants derived from them after each change.
The payload appears at once, as the planned force's step at the grasp.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import mujoco
import numpy as np

from forte.execution.model import SimModel

AfterStep = Callable[[int, Any, Any], None]


def grasp_time(plan_dir: str | Path) -> float | None:
    """The grasp's time (s) recorded in ``plan_dir/plan.json``, ``None`` for a plan without one."""
    try:
        meta = json.loads((Path(plan_dir) / "plan.json").read_text())
        value = meta["solver"]["goal"]["grasp_time_s"]
    except (OSError, ValueError, KeyError, TypeError):
        return None
    return float(value) if isinstance(value, int | float) and np.isfinite(value) and value >= 0 else None


class Attach:
    """An ``after_step`` that gives the carried body its full mass at ``time`` (s); built with the
    body at ``share`` of it (:func:`attach_at_grasp`)."""

    def __init__(self, sim: SimModel, time: float, share: float) -> None:
        self.sim, self.time, self.done = sim, float(time), False
        body = sim.payload_body
        self.mass, self.inertia = float(sim.model.body_mass[body]), sim.model.body_inertia[body].copy()
        self._set(share)

    def _set(self, share: float) -> None:
        m, body = self.sim.model, self.sim.payload_body
        m.body_mass[body] = share * self.mass
        m.body_inertia[body] = share * self.inertia
        mujoco.mj_setConst(m, mujoco.MjData(m))  # scratch data: it computes at qpos0

    def __call__(self, k: int, q: Any, dq: Any) -> None:
        if not self.done and (k + 1) * self.sim.timestep >= self.time - 1e-12:
            self._set(1.0)
            self.done = True


def attach_at_grasp(plan_dir: str | Path, sim: SimModel, plan: Any) -> Attach | None:
    """The payload's attachment at the grasp of ``plan`` (read from ``plan_dir``; ``None``: no
    grasp, or no carried body). The robot's tool load is carried throughout when the plan has a
    payload mass (as :func:`~forte.execution.run.simulate_plan` builds the body)."""
    time = grasp_time(plan_dir)
    if time is None or sim.payload_body < 0 or sim.model.body_mass[sim.payload_body] <= 0:
        return None
    tool = float(plan.robot.tool_force_mass) if plan.payload.mass is not None else 0.0
    return Attach(sim, time, min(tool / float(sim.model.body_mass[sim.payload_body]), 1.0))


def attach_facts(attach: Attach | None) -> dict[str, float]:
    """What sim.json records of the attachment: the grasp's time (s); nothing without one."""
    return {} if attach is None else {"grasp_time_s": attach.time}


def chained(*steps: AfterStep | None) -> AfterStep | None:
    """One ``after_step`` calling each of ``steps`` in order (``None`` entries left out)."""
    kept = [s for s in steps if s is not None]
    if len(kept) <= 1:
        return kept[0] if kept else None

    def after_step(k: int, q: Any, dq: Any) -> None:
        for step in kept:
            step(k, q, dq)

    return after_step
