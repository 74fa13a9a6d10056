"""The record of a simulated run: statistics over every control step and the ``sim.csv`` columns
of every ``record_every``-th one (the columns are listed in :mod:`forte.execution.run`)."""

from __future__ import annotations

import io
import json
from pathlib import Path
from typing import Any

import numpy as np

from forte.execution.control import ArmCommand
from forte.execution.judge import SimResult
from forte.io.outputs import atomic_write
from forte.model.robot import N_BASE
from forte.model.trajectory import trajectory_header
from forte.validation import FloatArray


class RunLog:
    """Statistics over every control step and the log columns of every ``record_every``-th one."""

    def __init__(self, steps: int, record_every: int, nq: int, tau_max: FloatArray) -> None:
        n = tau_max.size
        self.tau_max = tau_max
        self.rec_idx = list(range(0, steps, max(1, int(record_every))))
        if self.rec_idx[-1] != steps - 1:
            self.rec_idx.append(steps - 1)
        nrec = len(self.rec_idx)
        self.q_err = np.zeros((nrec, nq))
        self.q = np.zeros((nrec, nq))
        self.dq = np.zeros((nrec, nq))
        self.tau = np.zeros((nrec, n))
        self.sat = np.zeros((nrec, n))
        self.ee = np.zeros((nrec, 3))
        self.sat_window = np.zeros(n, dtype=bool)
        self.sat_steps = np.zeros(n)
        self.max_ratio = np.zeros(n)
        self.ee_err_max = 0.0
        self.ee_sq = 0.0
        self.qa_err_max = 0.0
        self.rows = 0

    def add(self, k: int, q: FloatArray, dq: FloatArray, q_d: FloatArray, ee_err: FloatArray,
            cmd: ArmCommand) -> None:
        """Account for control step ``k`` (state ``q, dq``, reference ``q_d``, command ``cmd``)."""
        # Saturation is OR-ed over each recording window so no event is lost.
        self.sat_window |= cmd.saturated
        self.sat_steps += cmd.saturated
        self.max_ratio = np.maximum(self.max_ratio, np.abs(cmd.tau_raw) / self.tau_max)
        e_norm = float(np.linalg.norm(ee_err))
        self.ee_err_max = max(self.ee_err_max, e_norm)
        self.ee_sq += e_norm**2
        self.qa_err_max = max(self.qa_err_max, float(np.abs(q_d[N_BASE:] - q[N_BASE:]).max()))
        r = self.rows
        if r < len(self.rec_idx) and k == self.rec_idx[r]:
            e_q = q_d - q
            e_q[2] = (e_q[2] + np.pi) % (2 * np.pi) - np.pi
            self.q_err[r], self.tau[r], self.sat[r], self.ee[r] = e_q, cmd.tau, self.sat_window, ee_err
            self.q[r], self.dq[r] = q, dq
            self.sat_window[:] = False
            self.rows += 1

    def columns(self, t: FloatArray) -> dict[str, FloatArray]:
        """The recorded rows as named columns (see the module docstring)."""
        r, n = self.rows, self.tau_max.size
        log: dict[str, FloatArray] = {"t": t[self.rec_idx[:r]]}
        for i, name in enumerate(trajectory_header(n)[1:]):
            log[f"e_{name}"] = self.q_err[:r, i]
        for i in range(n):
            log[f"tau{i + 1}"] = self.tau[:r, i]
        for i in range(n):
            log[f"sat{i + 1}"] = self.sat[:r, i]
        for i, axis in enumerate("xyz"):
            log[f"ee_err_{axis}"] = self.ee[:r, i]
        log["ee_err"] = np.linalg.norm(self.ee[:r], axis=1)
        for i, name in enumerate(trajectory_header(n)[1:]):
            log[name] = self.q[:r, i]
        for i, name in enumerate(trajectory_header(n)[1:]):
            log[f"d{name}"] = self.dq[:r, i]
        return log

    def summary(self, steps_run: int) -> dict[str, Any]:
        """Error and torque statistics over the ``steps_run`` steps simulated."""
        return {
            "max_ee_error_m": self.ee_err_max,
            "rms_ee_error_m": float(np.sqrt(self.ee_sq / max(steps_run, 1))),
            "max_arm_joint_error_rad": self.qa_err_max,
            "max_torque_ratio": self.max_ratio.tolist(),
            "saturation_fraction": (self.sat_steps / max(steps_run, 1)).tolist(),
        }


def write_results(result: SimResult, out_dir: Path) -> tuple[Path, Path]:
    """Atomically write ``sim.csv`` (the log) and ``sim.json`` (verdict + summary) to ``out_dir``."""
    out_dir.mkdir(parents=True, exist_ok=True)
    names = list(result.log)
    table = np.column_stack([result.log[n] for n in names]) if names else np.zeros((0, 0))
    buf = io.StringIO()
    buf.write(",".join(names) + "\n")
    np.savetxt(buf, table, delimiter=",", fmt="%.6g")
    csv_path, json_path = out_dir / "sim.csv", out_dir / "sim.json"
    atomic_write(csv_path, buf.getvalue())
    atomic_write(json_path, json.dumps(result.to_json(), indent=1) + "\n")
    return csv_path, json_path
