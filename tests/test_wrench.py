"""Wrench requirement and the 6-D residual wrench polytope and metric (issue 25, items 1-2)."""

from __future__ import annotations

import csv
import json
from dataclasses import replace
from pathlib import Path

import casadi as ca
import numpy as np
import pinocchio as pin
import pytest
import yaml
from conftest import random_configuration
from scipy.optimize import linprog

from forte.capability.metrics import (
    CapabilityParameters,
    capability_margin,
    capability_penalty,
    normalization,
    signed_distances,
    smooth_capability_penalty,
    smooth_penalty_expr,
)
from forte.capability.polytope import contains, directional_capacity, halfspaces, residual_margins, trajectory_rfp
from forte.capability.wrench import (
    smooth_wrench_penalty,
    smooth_wrench_penalty_expr,
    trajectory_wrench_margin,
    wrench_capacity,
    wrench_halfspaces,
    wrench_jacobian,
    wrench_margin,
    wrench_metrics,
    wrench_signed_distances,
)
from forte.cli.main import main
from forte.force.taskforce import TaskForce
from forte.force.wrench import angular_rates, payload_moment
from forte.io.plandir import METRIC_COLUMNS, read_metrics, read_plan_dir, write_plan
from forte.model.trajectory import backward_differences
from forte.model.twin import CasadiTwin
from forte.planning.methods.catalog import get_method
from forte.planning.planner import plan
from forte.planning.tasks.tasks import load_task
from forte.planning.terms.wrench_terms import WRENCH_TERM, for_requirement, term_values
from forte.planning.verdict.evaluation import evaluate

EXAMPLES = Path(__file__).resolve().parents[1] / "examples" / "tasks"
PARAMS = CapabilityParameters(alpha=0.8)


def random_states(robot, count, seed):
    """``count`` random (q, tau_nom) with random arm velocities and accelerations."""
    rng = np.random.default_rng(seed)
    for _ in range(count):
        q = random_configuration(robot, rng)
        tau = robot.rnea(q[3:], rng.normal(0, 0.5, robot.n_arm), rng.normal(0, 1.0, robot.n_arm))
        yield q, tau, rng


def test_zero_offset_is_the_force_metric_to_1e9(robot):
    """No moment (c = 0, no inertia: m = 0, r_m = 0, L = 0): every facet distance, the margin, the
    capacity along the requirement and the smooth penalty (numpy and CasADi) are the 3-D ones."""
    checked = 0
    for q, tau, rng in random_states(robot, 25, 3):
        margins = residual_margins(tau, robot.torque_limits)
        J6 = wrench_jacobian(robot, q)
        A, b = halfspaces(J6[:3], *margins, alpha=PARAMS.alpha)
        A6, b6 = wrench_halfspaces(J6, *margins, alpha=PARAMS.alpha)
        f, r = rng.normal(0, 30, 3), rng.uniform(0, 15)
        w = np.r_[f, 0.0, 0.0, 0.0]
        d3, d6 = signed_distances(A, b, f, r), wrench_signed_distances(A6, b6, w, r, 0.0, 0.0)
        finite = np.isfinite(d3)
        assert np.array_equal(finite, np.isfinite(d6)) and np.array_equal(d3[~finite], d6[~finite])
        np.testing.assert_allclose(d6[finite], d3[finite], rtol=0, atol=1e-9)
        assert wrench_margin(A6, b6, w, r, 0.0, 0.0) == pytest.approx(capability_margin(A, b, f, r), abs=1e-9)
        cap3, cap6 = directional_capacity(A, b, f), wrench_capacity(A6, b6, w)
        assert cap6 == pytest.approx(cap3, abs=1e-9) or cap6 == cap3
        s3 = smooth_capability_penalty(A, b, f, np.asarray(r), PARAMS)
        s6 = smooth_wrench_penalty(A6, b6, w, np.asarray(r), np.asarray(0.0), 0.0, PARAMS)
        assert s6 == pytest.approx(s3, rel=1e-9, abs=1e-12)
        e3 = float(smooth_penalty_expr(ca.DM(J6[:3]), ca.DM(tau), ca.DM(robot.torque_limits), ca.DM(f), r, PARAMS))
        e6 = float(smooth_wrench_penalty_expr(ca.DM(J6), ca.DM(tau), ca.DM(robot.torque_limits), ca.DM(f),
                                              ca.DM.zeros(3), r, 0.0, 0.0, PARAMS))
        assert e6 == pytest.approx(e3, rel=1e-9, abs=1e-12) and e6 == pytest.approx(float(s6), rel=1e-9, abs=1e-12)
        checked += int(np.isfinite(capability_margin(A, b, f, r)))
    assert checked >= 20


def test_zero_offset_task_keeps_today_s_numbers(robot):
    """A payload at the hand (com [0, 0, 0]) needs no moment: the plain force and metrics.csv; and
    the 6-D columns computed with a zero moment equal today's to 1e-9 along the lift."""
    task = load_task(EXAMPLES / "lift.yaml")
    zero = task.with_payload(replace(task.payload, com=(0.0, 0.0, 0.0)))
    assert not zero.force().has_moment and zero.force().m is None
    q, force = task.nominal(), task.force()
    today = evaluate(task.robot, q, task.t, force, task.settings.capability_params)
    assert "mx" not in today
    as_wrench = replace(force, m=np.zeros_like(force.f))  # a wrench requirement with m = 0, r_m = 0, L = 0
    six = wrench_metrics(task.robot, q, task.t, as_wrench, task.settings.alpha)
    for name in ("d", "directional_capacity", "capacity_margin", "max_torque_ratio_with_force"):
        np.testing.assert_allclose(six[name], today[name], rtol=0, atol=1e-9, err_msg=name)
    rfp = trajectory_rfp(task.robot, q, task.t, alpha=task.settings.alpha)
    np.testing.assert_allclose(trajectory_wrench_margin(task.robot, q, task.t, as_wrench, task.settings.alpha),
                               capability_margin(rfp.A, rfp.b, force.f, force.r), rtol=0, atol=1e-9)


def test_the_6x_n_jacobian_three_ways(robot):
    """Pinocchio's frame Jacobian, the CasADi twin's and finite differences of the pose agree."""
    twin = CasadiTwin(robot).functions()["arm_wrench_jacobian"]
    rng = np.random.default_rng(4)
    h = 1e-6
    for _ in range(5):
        q = random_configuration(robot, rng)
        J6 = wrench_jacobian(robot, q)
        np.testing.assert_allclose(np.array(twin(q)), J6, atol=1e-9)
        T0 = robot.ee_pose(q)
        for i in range(robot.n_arm):
            dq = np.zeros(robot.nq)
            dq[3 + i] = h
            T1 = robot.ee_pose(q + dq)
            np.testing.assert_allclose((T1[:3, 3] - T0[:3, 3]) / h, J6[:3, i], atol=1e-5)
            np.testing.assert_allclose(pin.log3(T1[:3, :3] @ T0[:3, :3].T) / h, J6[3:, i], atol=1e-5)


def test_polytope_against_pycapacity_and_two_linear_programs(robot):
    """The support function ``max u^T w`` of the residual wrench polytope along random directions:
    over pycapacity's vertices, by an LP on ``A w <= b`` and by an LP in torque space
    (``J6^T w = tau``, ``tau`` in the residual box), at random configurations."""
    pycapacity = pytest.importorskip("pycapacity.robot")
    checked = 0
    for q, tau, rng in random_states(robot, 12, 11):
        J6 = wrench_jacobian(robot, q)
        A, b = wrench_halfspaces(J6, *residual_margins(tau, robot.torque_limits))
        if not np.all(b > 0):
            continue  # pycapacity's enumeration assumes the bias inside the limits
        V = pycapacity.force_polytope(J6, robot.torque_limits, -robot.torque_limits, tau).vertices.T
        assert np.all(contains(A, b, V, tol=1e-6 * np.abs(b).max()))
        lo, hi = -robot.torque_limits - tau, robot.torque_limits - tau
        n = robot.n_arm
        for u in rng.normal(size=(10, 6)):
            ours = -linprog(-u, A_ub=A, b_ub=b, bounds=[(None, None)] * 6, method="highs").fun
            torque = linprog(np.r_[-u, np.zeros(n)], A_eq=np.hstack([J6.T, -np.eye(n)]), b_eq=np.zeros(n),
                             bounds=[(None, None)] * 6 + list(zip(lo, hi, strict=True)), method="highs")
            scale = max(1.0, abs(ours))
            assert np.max(V @ u) == pytest.approx(ours, abs=1e-6 * scale)
            assert -torque.fun == pytest.approx(ours, abs=1e-6 * scale)
        checked += 1
    assert checked >= 5


def test_margin_is_the_scaled_distance_and_its_sign_is_containment(robot):
    """Per facet: ``d_i >= 0`` exactly when the set's extreme point for that facet satisfies it, and
    moving that point by ``d_i`` along the facet's scaled normal lands on the facet; sampled points
    of the set are inside the polytope whenever ``d_k >= 0``."""
    seen = set()
    for q, tau, rng in random_states(robot, 30, 21):
        A, b = wrench_halfspaces(wrench_jacobian(robot, q), *residual_margins(tau, robot.torque_limits), 0.9)
        w = np.r_[rng.normal(0, 15, 3), rng.normal(0, 2, 3)]
        r, L = rng.uniform(0, 10), rng.uniform(0.05, 0.3)
        r_m = L * r
        d = wrench_signed_distances(A, b, w, r, r_m, L)
        af, am = A[:, :3], A[:, 3:]
        nf, nm = np.linalg.norm(af, axis=1), np.linalg.norm(am, axis=1)
        unit = np.hstack([af / np.where(nf > 0, nf, 1.0)[:, None], am / np.where(nm > 0, nm, 1.0)[:, None]])
        extreme = w + unit * np.r_[np.full(3, r), np.full(3, r_m)]  # the set's farthest point along each row
        inside = np.einsum("ij,ij->i", A, extreme) <= b
        assert np.array_equal(d >= 0, inside)
        step = np.hstack([af, L**2 * am]) / np.sqrt(nf**2 + L**2 * nm**2)[:, None]
        landed = np.einsum("ij,ij->i", A, extreme + d[:, None] * step)
        np.testing.assert_allclose(landed, b, atol=1e-9 * np.abs(b).max())
        df = rng.normal(size=(400, 3))
        dm = rng.normal(size=(400, 3))
        df *= r * rng.uniform(0, 1, (400, 1)) ** (1 / 3) / np.linalg.norm(df, axis=1, keepdims=True)
        dm *= r_m * rng.uniform(0, 1, (400, 1)) ** (1 / 3) / np.linalg.norm(dm, axis=1, keepdims=True)
        if d.min() >= 0:
            assert np.all(contains(A, b, w + np.hstack([df, dm])))
        seen.add(bool(d.min() >= 0))
    assert seen == {True, False}


def test_smooth_surrogate_bounds_and_converges_to_the_exact_wrench_penalty(robot):
    """As the 3-D surrogate: an upper bound of ``c_k`` whose exponent error is at most
    ``kappa (log(1 + 2n) + knee) / beta``, shrinking with ``beta``."""
    cases = []
    for q, tau, rng in random_states(robot, 30, 17):
        L = rng.uniform(0.05, 0.3)
        cases.append((wrench_jacobian(robot, q), tau, np.r_[rng.normal(0, 25, 3), rng.normal(0, 4, 3)],
                      rng.uniform(0, 12), L))
    previous = np.inf
    for beta in (10.0, 100.0, 1000.0, 1e5):
        params = CapabilityParameters(beta=beta, eps_normal=1e-9)
        worst = 0.0
        for J6, tau, w, r, L in cases:
            A, b = wrench_halfspaces(J6, *residual_margins(tau, robot.torque_limits), params.alpha)
            exact = float(capability_penalty(wrench_margin(A, b, w, r, L * r, L), normalization(w[:3], r),
                                             params.kappa, params.max_exponent))
            smooth = float(smooth_wrench_penalty(A, b, w, np.asarray(r), np.asarray(L * r), L, params))
            assert smooth >= exact - 1e-9 * (1 + exact)
            worst = max(worst, abs(np.log1p(smooth) - np.log1p(exact)))
        assert worst <= params.kappa * (np.log(15) + params.knee) / beta + 1e-9
        assert worst < previous
        previous = worst
    assert previous < 1e-3


def test_an_inertia_alone_needs_a_moment_measured_in_newtons(robot):
    """A payload at the hand with an inertia: the moment is ``I alpha + omega x I omega`` only,
    ``L = 0`` (no lever), and the columns are finite where the force metric's are."""
    task = load_task(EXAMPLES / "lift.yaml")
    spun = task.with_payload(replace(task.payload, inertia=((0.05, 0, 0), (0, 0.04, 0), (0, 0, 0.03))))
    force = spun.force()
    assert force.has_moment and force.lever == 0.0 and force.moment_scale == 0.0
    R = task.targets[:, :3, :3]
    np.testing.assert_allclose(force.m, payload_moment(task.t, R, np.zeros((task.n, 3)), np.zeros(3),
                                                       np.diag([0.05, 0.04, 0.03])), atol=1e-12)
    assert 0 < np.abs(force.m).max() < 0.05  # the lift turns the hand slowly
    q = task.nominal()
    with_inertia = evaluate(task.robot, q, task.t, force, task.settings.capability_params)
    plain = evaluate(task.robot, q, task.t, task.force(), task.settings.capability_params)
    assert np.array_equal(np.isfinite(with_inertia["d"]), np.isfinite(plain["d"]))
    np.testing.assert_allclose(with_inertia["d"], plain["d"], atol=0.1)


def test_moment_of_a_spinning_payload_by_hand():
    """Constant angular velocity about a tilted axis: ``omega`` from the orientations, ``alpha`` only
    on the first step, and ``m = c x f + I alpha + omega x I omega`` written out."""
    dt, n = 0.1, 6
    omega = np.array([0.3, -0.2, 0.5])
    t = dt * np.arange(n)
    R = np.array([pin.exp3(omega * tk) for tk in t])
    w, a = angular_rates(t, R)
    np.testing.assert_allclose(w[1:], np.tile(omega, (n - 1, 1)), atol=1e-12)
    np.testing.assert_allclose(a[1], omega / dt, atol=1e-12)
    np.testing.assert_allclose(a[2:], 0.0, atol=1e-9)
    assert np.all(w[0] == 0) and np.all(a[0] == 0)
    I, c = np.diag([0.02, 0.03, 0.04]), np.array([0.1, 0.0, -0.2])
    f = np.tile([1.0, 2.0, 30.0], (n, 1))
    m = payload_moment(t, R, f, c, I)
    for k in range(n):
        Ik = R[k] @ I @ R[k].T
        expected = np.cross(R[k] @ c, f[k]) + Ik @ a[k] + np.cross(w[k], Ik @ w[k])
        np.testing.assert_allclose(m[k], expected, atol=1e-12)
    np.testing.assert_allclose(payload_moment(t, R, f, c), np.cross(R @ c, f), atol=1e-12)  # a point mass


def test_moment_columns_against_m_a_minus_g_and_the_offset_by_hand(tmp_path):
    """``mx, my, mz`` of metrics.csv are ``(R_k c) x m (p''_k - g)``, the payload's share only;
    ``max_torque_ratio_with_force`` uses ``J6^T w``; plan.json keeps ``com`` and the moment scale."""
    task = load_task(EXAMPLES / "offset-payload.yaml")
    result = plan(task, "quintic")
    mass, c = 2.7, np.array([0.0, -0.2, 0.0])
    _, acc = backward_differences(task.targets[:, :3, 3], task.t)
    f_payload = mass * (acc - np.array([0.0, 0.0, -task.robot.gravity]))
    moment = np.cross(task.targets[:, :3, :3] @ c, f_payload)
    m = result.metrics
    np.testing.assert_allclose(np.column_stack([m["mx"], m["my"], m["mz"]]), moment, atol=1e-9)
    np.testing.assert_allclose(np.column_stack([m["fx"], m["fy"], m["fz"]]),
                               f_payload * (mass + task.robot.tool_force_mass) / mass, atol=1e-9)
    assert np.abs(moment).max() > 5.0  # 2.7 kg at 0.2 m: 5.3 N m
    J6 = np.array([wrench_jacobian(task.robot, qk) for qk in result.q])
    qa = result.q[:, 3:]
    v, a = backward_differences(qa, task.t)
    tau = np.array([task.robot.rnea(*x) for x in zip(qa, v, a, strict=True)])
    w = np.hstack([np.column_stack([m["fx"], m["fy"], m["fz"]]), moment])
    ratio = np.max(np.abs(tau + np.einsum("kij,ki->kj", J6, w)) / task.robot.torque_limits, axis=1)
    np.testing.assert_allclose(m["max_torque_ratio_with_force"], ratio, atol=1e-9)
    out = write_plan(result, tmp_path / "quintic", figures=False)
    header = next(csv.reader((out / "metrics.csv").open()))
    assert header == [*METRIC_COLUMNS, "mx", "my", "mz", "tipover_margin"]  # the MOCA base states its footprint
    doc = json.loads((out / "plan.json").read_text())
    assert doc["payload"]["com"] == [0.0, -0.2, 0.0] and doc["payload"]["moment_scale"] == pytest.approx(0.2)
    assert doc["force"]["lever_m"] == pytest.approx(0.2) and doc["force"]["moment_scale"] == pytest.approx(0.2)
    back = read_plan_dir(out)
    np.testing.assert_allclose(back.force.m, moment, atol=1e-9)
    assert back.payload.com == (0.0, -0.2, 0.0)
    np.testing.assert_array_equal(read_metrics(out)["mz"], m["mz"])  # written with full precision


def test_the_wrench_term_and_the_method_that_uses_it(robot):
    """The optimizer's stage expression equals the numpy surrogate at a random waypoint; ``forte``
    is solved with ``wrench_capability`` when the force carries a moment, unchanged otherwise."""
    from forte.planning.terms.costs import Stage
    from forte.planning.terms.wrench_terms import WrenchCapability

    twin = CasadiTwin(robot)
    nq = robot.nq
    syms = [ca.SX.sym(s, nq) for s in ("q2", "q1", "q0")] + [ca.SX.sym("dt1"), ca.SX.sym("dt0")]
    f, r = ca.SX.sym("f", 3), ca.SX.sym("r")
    params = {name: ca.SX.sym(name, size) for name, size in WrenchCapability.parameters}
    stage = Stage(twin, *syms, f, r, params)
    fn = ca.Function("c", [*syms, f, r, *params.values()], [WrenchCapability(PARAMS).stage(stage)])
    rng = np.random.default_rng(2)
    q0 = random_configuration(robot, rng)
    q1, q2 = q0 - 0.01 * rng.normal(size=nq), q0 - 0.03 * rng.normal(size=nq)
    fk, mk, rk, L = rng.normal(0, 20, 3), rng.normal(0, 3, 3), 8.0, 0.2
    value = float(fn(q2, q1, q0, 0.25, 0.25, fk, rk, mk, L * rk, L))
    v0, v1 = (q0[3:] - q1[3:]) / 0.25, (q1[3:] - q2[3:]) / 0.25
    tau = robot.rnea(q0[3:], v0, (v0 - v1) / 0.25)
    A, b = wrench_halfspaces(wrench_jacobian(robot, q0), *residual_margins(tau, robot.torque_limits), PARAMS.alpha)
    expected = smooth_wrench_penalty(A, b, np.r_[fk, mk], np.asarray(rk), np.asarray(L * rk), L, PARAMS)
    assert value == pytest.approx(float(expected), rel=1e-9)
    forte = get_method("forte")
    force = TaskForce(np.arange(3.0), np.ones((3, 3)), np.ones(3))
    assert for_requirement(forte, force) is forte and term_values(force) == {}
    wrench = replace(force, m=np.zeros((3, 3)) + 0.5, lever=0.2, moment_scale=0.2)
    solved = for_requirement(forte, wrench)
    assert solved.name == "forte" and WRENCH_TERM in solved.terms and "capability" not in solved.terms
    values = term_values(wrench)
    assert values["moment"].shape == (9,) and np.allclose(values["moment_radius"], 0.2)


def test_an_offset_payload_plan_keeps_the_wrench_margin_the_force_only_plan_loses():
    """offset-payload.yaml (the lift, 2.7 kg with its centre of mass 0.2 m to the side of the hand):
    forte on the wrench keeps ``d >= 0``; forte on the force alone (the same task without ``com``)
    is feasible for the force but leaves the alpha-scaled wrench polytope (measured: min d = -2.5 N
    against +1.7 N; its wrist torques stay below their limits, 0.85 x at worst)."""
    task = load_task(EXAMPLES / "offset-payload.yaml")
    force_only = task.with_payload(replace(task.payload, com=None))
    wrench_plan, force_plan = plan(task, "forte"), plan(force_only, "forte")
    assert wrench_plan.feasible and wrench_plan.solver["cost_terms"].get(WRENCH_TERM) is not None
    assert np.min(wrench_plan.metrics["d"]) >= 0
    assert force_plan.feasible and "mx" not in force_plan.metrics  # feasible for the force alone
    judged = evaluate(task.robot, force_plan.q, task.t, task.force(), task.settings.capability_params)
    assert np.min(judged["d"]) < -1.0
    from forte.planning.verdict.verdict import judge_plan

    assert "capacity" in judge_plan(task, force_plan.q, task.force()).failed


BAD_PAYLOADS = [
    ({"com": [0.0, 0.2]}, "payload.com: expected a list of 3 numbers"),
    ({"com": "left"}, "payload.com: expected a list of 3 numbers"),
    ({"com": [0.0, 0.0, 5.0]}, "payload.com: expected finite numbers at most 2 m"),
    ({"inertia": [-0.1, 0.02, 0.02]}, "payload.inertia: expected moments >= 0"),
    ({"inertia": [0.1, 0.01, 0.01]}, "payload.inertia: principal moments"),
    ({"inertia": [[0.1, 0.05, 0], [0, 0.1, 0], [0, 0, 0.1]]}, "payload.inertia: expected a symmetric matrix"),
    ({"inertia": [[0.1, 0], [0, 0.1]]}, "payload.inertia: expected a 3x3 matrix"),
    ({"moment_scale": -1}, "payload.moment_scale: expected a number > 0"),
    ({"mass": None, "description": None}, "payload.mass: a payload with com or inertia needs a mass"),
]


@pytest.mark.parametrize(("change", "message"), BAD_PAYLOADS)
def test_bad_payload_geometry_is_one_line_naming_the_field_exit_2(tmp_path, capsys, change, message):
    data = yaml.safe_load((EXAMPLES / "offset-payload.yaml").read_text())
    data["payload"].update(change)
    data["payload"] = {k: v for k, v in data["payload"].items() if v is not None}
    path = tmp_path / "task.yaml"
    path.write_text(yaml.safe_dump(data))
    assert main(["plan", str(path), "--out", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err and str(path) in err, err
