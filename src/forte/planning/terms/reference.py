"""Numeric references of the cost terms (numpy), for tests, benchmarks and reports.

They evaluate the same formulas as the compiled terms of :mod:`forte.planning.terms.costs` without
CasADi's code generation, so the two can be checked against each other.
"""

from __future__ import annotations

from typing import Any

import casadi as ca
import numpy as np

from forte.model.robot import N_BASE
from forte.model.twin import CasadiTwin
from forte.planning.terms.capability_terms import Capability
from forte.planning.terms.costs import Stage
from forte.planning.terms.motion_terms import BaseSmoothness, BaseSpectral, Smoothness, dct_penalty_matrix
from forte.settings import CapabilityParameters
from forte.validation import FloatArray


def smoothness_weights(n_arm: int, settings: Any = None) -> FloatArray:
    """Diagonal of ``W_s`` (base x, y, yaw, then the arm joints) for ``settings`` (term -> {setting:
    value}); with ``base_smoothness.linear`` the base entries are ``sqrt(base)``, so that ``W_s^2``
    is the metric used linearly."""
    base_term, arm_term = BaseSmoothness.from_settings(settings), Smoothness.from_settings(settings)
    base = np.asarray(base_term.base, dtype=float)
    return np.concatenate([np.sqrt(base) if base_term.linear else base, np.full(n_arm, arm_term.arm)])


def base_spectral_cost(base: FloatArray, settings: Any = None) -> float:
    """Numeric J5 = 1/2 sum_xi eta_xi sum_{l in H} gamma_l bhat_{xi,l}^2 for base (N x 3)."""
    base = np.asarray(base, dtype=float)
    P = dct_penalty_matrix(base.shape[0], settings)
    axis = BaseSpectral.from_settings(settings).axis
    return 0.5 * float(sum(eta * base[:, i] @ P @ base[:, i] for i, eta in enumerate(axis)))


def smoothness_cost(q: FloatArray, settings: Any = None) -> float:
    """Numeric J4 = sum_k 1/2 ||W_s (q_k - q_{k-1})||^2."""
    q = np.asarray(q, dtype=float)
    W = smoothness_weights(q.shape[1] - N_BASE, settings)
    return 0.5 * float(np.sum((np.diff(q, axis=0) * W) ** 2))


def capability_stage(twin: CasadiTwin, params: CapabilityParameters) -> ca.Function:
    """``c_k(q_{k-2}, q_{k-1}, q_k, dt_{k-1}, dt_k, f_k, r_k)``: the capability term alone, as a function."""
    nq = twin.robot.nq
    s = Stage(twin, ca.SX.sym("q_prev2", nq), ca.SX.sym("q_prev", nq), ca.SX.sym("q", nq),
              ca.SX.sym("dt_prev"), ca.SX.sym("dt"), ca.SX.sym("f", 3), ca.SX.sym("r"))
    return ca.Function("capability", [s.q2, s.q1, s.q0, s.dt1, s.dt0, s.f, s.r], [Capability(params).stage(s)])
