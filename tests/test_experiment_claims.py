"""How the experiments judge the paper's claims, on hand-made plans and simulations (no planning, fast).

Rules under test (see :mod:`forte.experiments.claims`): a simulation claim holds only if it holds
in every run (nominal and each mass-error trial); a claim about a plan needs a solved plan; the
claims table holds the paper's claims only; every claim that is not reproduced carries a cause.
"""

from __future__ import annotations

import argparse
import json
from types import SimpleNamespace

import numpy as np
import pytest

from forte.cli import experiment as cli_experiment
from forte.exceptions import InvalidInputError
from forte.experiments import common
from forte.experiments.claims import (
    Check,
    Claim,
    across_trials,
    claims_section,
    compare,
    every_run,
    runs,
    solved,
    some_run_fails,
    unloaded_succeeds,
)
from forte.experiments.common import Case, paper_methods, style, write_summary
from forte.experiments.continuous import continuous_claims
from forte.experiments.hold import clip_polygon, polytope_section
from forte.experiments.lift import lift_claims, lift_notes

T = np.linspace(0.0, 6.0, 7)


def fake_plan(method: str, cap: float, mu: float = 0.2, mag: float = 26.5, r: float = 10.0, d: float = 1.0,
              success: bool = True, t: np.ndarray = T) -> SimpleNamespace:
    """A plan with constant metrics: capacity along f, manipulability, |f|, r and d."""
    n = len(t)
    full = np.full(n, 1.0)
    label = "feasible" if success else "solver-failed"
    verdict = SimpleNamespace(label=label, failed=() if success else ("solver",),
                              brief=lambda: "" if success else "solver (Maximum_Iterations_Exceeded)")
    return SimpleNamespace(
        method=method, t=t, solved=success, feasible=success, label=label, verdict=verdict,
        status="Solve_Succeeded" if success else "Maximum_Iterations_Exceeded",
        solver={}, force=SimpleNamespace(magnitude=mag * full, r=r * full),
        metrics={"directional_capacity": cap * full, "capacity_margin": (cap - mag - r) * full, "d": d * full,
                 "manipulability": mu * full, "max_torque_ratio": 0.5 * full,
                 "max_torque_ratio_with_force": 0.6 * full})


def sim(nominal: bool, *trials: bool, mass: float = 2.7) -> dict:
    """A simulation record: nominal outcome plus mass-error trials (True = success)."""
    def run(ok: bool, m: float) -> dict:
        return {"mass": m, "success": ok, "reason": None if ok else "torque saturation",
                "failure_time": None if ok else 1.25}
    out = {"verdict": "success" if nominal else "failure", "reason": None if nominal else "torque saturation",
           "failure_time": None if nominal else 1.2}
    if trials:
        done = [run(ok, mass * (1 + 0.01 * (i + 1))) for i, ok in enumerate(trials)]
        out["trials"] = {"runs": done, "successes": sum(trials), "count": len(trials),
                         "failure_time_mean_std": (None, None)}
    return out


def case_with(sims: dict[str, dict], mass: float = 2.7) -> Case:
    return Case("2.7 L", mass, {m: fake_plan(m, 50.0) for m in sims}, sims)


# -- every run must agree --------------------------------------------------------------------
def test_a_success_claim_with_trials_ok_then_fail_is_not_reproduced():
    check = every_run(case_with({"forte": sim(True, True, False)}), "forte")
    claim = Claim("5.3", "forte lifts", "simulation", "-", [check])
    assert not check.ok and not claim.reproduced
    assert "2/3 runs ok" in check.evidence
    assert "trial 2 (2.75 kg): torque saturation at 1.25 s" in claim.cause


def test_the_issue_case_nominal_ok_and_its_only_trial_failing_is_not_reproduced():
    check = every_run(case_with({"forte": sim(True, False)}), "forte")
    assert not check.ok
    assert "1/2 runs ok" in check.evidence


def test_a_success_claim_holds_only_when_nominal_and_every_trial_succeed():
    assert every_run(case_with({"forte": sim(True, True, True)}), "forte").ok
    assert every_run(case_with({"forte": sim(True)}), "forte").ok  # no trials asked: the nominal run is every run
    assert not every_run(case_with({"forte": sim(False, True, True)}), "forte").ok


def test_a_failure_claim_needs_every_run_to_fail():
    assert every_run(case_with({"quintic": sim(False, False, False)}), "quintic", success=False).ok
    check = every_run(case_with({"quintic": sim(False, True)}), "quintic", success=False)
    assert not check.ok and "1/2 runs failed" in check.evidence and "trial 1" in check.evidence


def test_an_unsimulated_plan_is_no_evidence():
    case = Case("2.7 L", 2.7, {}, {"forte": {"verdict": "not simulated", "reason": "planning failed (no trajectory)"}})
    check = every_run(case, "forte")
    assert not check.ok and "planning failed" in check.evidence
    assert runs(case.sims["forte"]) == []
    assert not every_run(Case("2.7 L", 2.7), "forte").ok  # not even a record
    assert not some_run_fails(case, "forte").ok


def test_some_trials_claims_need_one_failed_run():
    assert some_run_fails(case_with({"manipulability": sim(True, True, False)}), "manipulability").ok
    check = some_run_fails(case_with({"manipulability": sim(True, True, True)}), "manipulability")
    assert not check.ok and check.evidence.startswith("0/3 runs failed")


def test_a_failure_from_the_load_needs_a_successful_unloaded_run():
    assert unloaded_succeeds({"quintic": {"label": "no payload", "mass": 0.0, "success": True}}, "quintic").ok
    bad = unloaded_succeeds({"quintic": {"label": "no payload", "mass": 0.0, "success": False,
                                         "reason": "tracking loss", "failure_time": 0.5}}, "quintic")
    assert not bad.ok and "tracking loss at 0.50 s" in bad.evidence
    assert not unloaded_succeeds({}, "quintic").ok


# -- checks and claims -----------------------------------------------------------------------
def test_a_claim_without_checks_is_not_reproduced():
    claim = Claim("5.3", "anything", "-", "-")
    assert not claim.reproduced and claim.cause == "nothing was measured"


@pytest.mark.parametrize(("value", "op", "bound", "ok"), [
    (1.0, ">=", 1.0, True), (1.0, ">", 1.0, False), (0.5, "<", 1.0, True), (1.0, "<=", 0.5, False),
    (float("nan"), "<", 1.0, False), (float("inf"), ">", 1.0, False), (-float("inf"), "<", 0.0, False)])
def test_compare_judges_and_never_passes_a_non_finite_value(value, op, bound, ok):
    assert compare("x", value, op, "y", bound).ok is ok


def test_a_claim_on_a_failed_solve_is_not_reproduced():
    results = {"forte": fake_plan("forte", 50.0, success=False), "manipulability": fake_plan("manipulability", 20.0)}
    check = solved(results, "forte", "manipulability")
    assert not check.ok and "forte: Maximum_Iterations_Exceeded" in check.evidence
    assert not solved(results, "rfp-cone").ok  # not planned at all
    assert solved(results, "manipulability").ok


def test_claims_of_repeated_plannings_must_hold_in_every_trial():
    ok = Claim("5.2", "c", "m", "ours 1", [Check("a", True, "1")])
    bad = Claim("5.2", "c", "m", "ours 2", [Check("a", False, "0")])
    (merged,) = across_trials([[ok], [bad]])
    assert not merged.reproduced
    assert "holds in 1/2 trials" in merged.ours and "planning trial 2" in merged.cause
    (both,) = across_trials([[ok], [ok]])
    assert both.reproduced
    assert across_trials([[bad]]) == [bad]


def test_every_claim_that_is_not_reproduced_gets_its_numbers_and_a_cause_line():
    claims = [Claim("5.3", "holds", "m", "ours 7.5 N", [compare("margin", 7.5, ">=", "0", 0.0, " N")]),
              Claim("5.3", "fails", "m", "ours -3.2 N", [compare("margin", -3.2, ">=", "0", 0.0, " N")])]
    text = "\n".join(claims_section(claims))
    assert "(1/2 reproduced)" in text
    cause_lines = [line for line in text.splitlines() if "Cause:" in line]
    assert len(cause_lines) == 1
    assert "ours -3.2 N" in cause_lines[0] and "expected margin ≥ 0, got -3.2 vs 0.0 N" in cause_lines[0]


def test_notes_stay_out_of_the_claims_table(tmp_path):
    claim = Claim("5.3", "the paper's claim", "m", "ours", [Check("a", False, "0")])
    write_summary(tmp_path, "t", [], [], [claim], [], {}, ["our own observation"])
    text = (tmp_path / "summary.md").read_text()
    table = text.split("## Paper claim vs our result")[1].split("## Notes")[0]
    assert "the paper's claim" in table and "our own observation" not in table
    assert "our own observation" in text.split("## Notes")[1]
    doc = json.loads((tmp_path / "summary.json").read_text())
    assert doc["notes"] == ["our own observation"]
    assert doc["claims"][0]["reproduced"] is False and doc["claims"][0]["cause"] == "expected a, got 0"


# -- the experiments' claims on hand-made plans ------------------------------------------------
def lift_cases(forte_sim: dict) -> tuple[list[Case], dict]:
    heavy_sims = {"forte": forte_sim, "manipulability": sim(False, False), "rfp-radius": sim(True, True),
                  "rfp-cone": sim(True, True), "quintic": sim(False, False)}
    heavy = Case("2.7 L", 2.7, {"forte": fake_plan("forte", 50.0, mu=0.17),
                                "manipulability": fake_plan("manipulability", 20.0, mu=0.21),
                                "rfp-radius": fake_plan("rfp-radius", 40.0, mu=0.2),
                                "rfp-cone": fake_plan("rfp-cone", 40.0, mu=0.2),
                                "quintic": fake_plan("quintic", 20.0, mu=0.07)}, heavy_sims)
    light = Case("0.33 L", 0.35, {m: fake_plan(m, c, mu=u, mag=3.4) for m, c, u in (
        ("forte", 20.0, 0.2), ("manipulability", 15.0, 0.21), ("rfp-radius", 30.0, 0.18), ("rfp-cone", 30.0, 0.18),
        ("quintic", 80.0, 0.07))}, {})
    unloaded = {m: {"label": "no payload", "mass": 0.0, "success": True} for m in heavy_sims}
    return [light, heavy], unloaded


def test_forte_lifts_is_judged_on_every_trial():
    cases, unloaded = lift_cases(sim(True, True, False))
    claims = {c.claim: c for c in lift_claims(cases, unloaded)}
    lifts = next(c for text, c in claims.items() if text.startswith("2.7 L: forte lifts"))
    assert not lifts.reproduced and "trial 2" in lifts.cause
    cases, unloaded = lift_cases(sim(True, True, True))
    lifts = next(c for c in lift_claims(cases, unloaded) if c.claim.startswith("2.7 L: forte lifts"))
    assert lifts.reproduced and lifts.cause is None


def test_the_hand_made_lift_reproduces_what_it_was_built_to():
    cases, unloaded = lift_cases(sim(True, True))
    verdicts = {c.claim: c.reproduced for c in lift_claims(cases, unloaded)}
    assert all(verdicts.values()), [k for k, v in verdicts.items() if not v]
    unloaded["quintic"] = {"label": "no payload", "mass": 0.0, "success": False, "reason": "unstable",
                           "failure_time": 0.1}
    quintic = next(c for c in lift_claims(cases, unloaded) if c.claim.startswith("2.7 L: quintic fails"))
    assert not quintic.reproduced and "without payload" in quintic.cause


def test_lift_claims_are_the_papers_and_the_issue_test_is_a_note():
    cases, unloaded = lift_cases(sim(True, True))
    texts = [c.claim.lower() for c in lift_claims(cases, unloaded)]
    assert not any("issue" in t or "implied" in t for t in texts)
    assert any("issue's test" in n for n in lift_notes(cases, unloaded))


def test_continuous_claims_fail_on_a_failed_solve_of_any_compared_method():
    t = np.linspace(0.0, 12.0, 13)
    mag = 100 * np.sin(np.pi * t / 12)

    def plan(method: str, cap: float, mu_high: float, ok: bool = True) -> SimpleNamespace:
        p = fake_plan(method, cap, t=t, success=ok)
        p.force.magnitude = mag
        p.metrics["manipulability"] = np.where(mag >= 50, mu_high, 0.2)
        return p

    good = {"forte": plan("forte", 120.0, 0.15), "manipulability": plan("manipulability", 80.0, 0.2),
            "rfp-radius": plan("rfp-radius", 80.0, 0.2), "rfp-cone": plan("rfp-cone", 80.0, 0.2)}
    assert all(c.reproduced for c in continuous_claims(good))
    good["rfp-cone"] = plan("rfp-cone", 80.0, 0.2, ok=False)
    first = continuous_claims(good)[0]
    assert not first.reproduced and "rfp-cone: Maximum_Iterations_Exceeded" in first.cause


# -- methods, figures, CLI -------------------------------------------------------------------
def test_every_compared_method_has_its_own_colour():
    methods = {m for e in ("continuous", "lift", "hold") for m in paper_methods(e)}
    colours = [style(m)[0] for m in methods]
    assert len(set(colours)) == len(methods)
    assert paper_methods("lift")[-1] == "quintic" and paper_methods("hold")[-1] == "teaching"


def test_polytope_section_of_a_cube():
    A = np.vstack([np.eye(3), -np.eye(3)])
    b = np.ones(6)
    sq = polytope_section(A, b, np.zeros(3), (-5.0, 5.0, -5.0, 5.0))
    x, z = sq[:, 0], sq[:, 1]
    area = 0.5 * abs(np.dot(x, np.roll(z, -1)) - np.dot(z, np.roll(x, -1)))
    assert area == pytest.approx(4.0)
    assert len(polytope_section(A, b, np.array([0.0, 2.0, 0.0]), (-5.0, 5.0, -5.0, 5.0))) == 0  # y = 2 misses it
    half = clip_polygon(np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]]), np.array([1.0, 0.0]), 1.0)
    assert half[:, 0].max() == pytest.approx(1.0) and len(half) == 4


def test_the_cli_offers_the_figure_formats_the_runners_accept():
    assert cli_experiment.FORMATS == common.FORMATS
    parser = argparse.ArgumentParser()
    cli_experiment.register(parser.add_subparsers(dest="command"))
    assert parser.parse_args(["experiment", "lift"]).fmt == "png"
    assert parser.parse_args(["experiment", "hold", "--format", "pdf"]).fmt == "pdf"
    with pytest.raises(SystemExit):
        parser.parse_args(["experiment", "hold", "--format", "jpg"])
    with pytest.raises(ValueError, match="svg"):
        common.check_format("jpg")


def recording_cli(monkeypatch, runner: str) -> tuple[argparse.ArgumentParser, dict]:
    """The ``forte experiment`` parser with ``runner`` replaced by a stub that records the keyword
    arguments the CLI passes (the real runs are in test_experiments)."""
    import forte.experiments as experiments

    seen: dict = {}

    def fake_run(out, **kwargs):
        seen.clear()
        seen.update(kwargs)
        out.mkdir(parents=True)
        (out / "summary.md").write_text("# stub\n")

    monkeypatch.setattr(experiments, runner, fake_run, raising=False)
    parser = argparse.ArgumentParser()
    cli_experiment.register(parser.add_subparsers(dest="command"))
    return parser, seen


def test_no_weight_sweep_reaches_the_runner_and_is_refused_where_there_is_none(tmp_path, monkeypatch, capsys):
    parser, seen = recording_cli(monkeypatch, "run_lift")
    args = parser.parse_args(["experiment", "lift", "--out", str(tmp_path / "l"), "--no-weight-sweep", "--quiet"])
    assert args.func(args) == 0 and seen["weight_factors"] == ()
    args = parser.parse_args(["experiment", "lift", "--out", str(tmp_path / "m"), "--quiet"])
    assert args.func(args) == 0 and "weight_factors" not in seen  # the runner's default sweep
    args = parser.parse_args(["experiment", "continuous", "--out", str(tmp_path / "c"), "--no-weight-sweep"])
    assert args.func(args) == 2
    assert "only lift and hold" in capsys.readouterr().err and not (tmp_path / "c").exists()


def test_weights_reach_the_runner_and_a_bad_set_is_one_line(tmp_path, monkeypatch, capsys):
    parser, seen = recording_cli(monkeypatch, "run_hold")
    args = parser.parse_args(["experiment", "hold", "--out", str(tmp_path / "h"), "--weights", "authors-hold-as-run",
                              "--quiet"])
    assert args.func(args) == 0 and seen["weights"] == "authors-hold-as-run"
    args = parser.parse_args(["experiment", "hold", "--out", str(tmp_path / "i"), "--quiet"])
    assert args.func(args) == 0 and "weights" not in seen  # the task file's set
    for name, value, expected in (("hold", "authors-hld", "expected one of"), ("continuous", "authors-trajectory",
                                                                               "only lift and hold")):
        out = tmp_path / f"bad-{name}"
        args = parser.parse_args(["experiment", name, "--out", str(out), "--weights", value])
        assert args.func(args) == 2
        err = capsys.readouterr().err
        assert expected in err and err.count("\n") == 1 and not out.exists()


# -- the RFP baselines at other capability weights -------------------------------------------
def sweep_points(points: dict[str, list[tuple[float, float, float, dict]]]) -> list:
    """SweepPoints from (weight, heavy capacity, light manipulability, heavy simulation) per method."""
    from forte.experiments.baseline_weights import SweepPoint
    return [SweepPoint(m, w, fake_plan(m, 20.0, mu=mu, mag=3.4), fake_plan(m, cap), s)
            for m, rows in points.items() for w, cap, mu, s in rows]


def test_no_weight_gives_a_baseline_forte_s_balance_is_judged_per_weight():
    from forte.experiments.baseline_weights import weight_claims
    forte_light = fake_plan("forte", 20.0, mu=0.2, mag=3.4)
    ok = sim(True, True, True)
    # enough force (capacity >= |f| + r = 36.5 N, every run ok) only where manipulability drops
    rows = [(60.0, 30.0, 0.19, sim(False, False)), (600.0, 40.0, 0.16, ok)]
    shift, balance = weight_claims(sweep_points({"rfp-radius": rows, "rfp-cone": rows}), forte_light, "5.3")
    assert shift.reproduced and balance.reproduced
    assert "sufficient from weight 600, where its 0.33 L manipulability is 0.1600" in balance.ours
    # a weight with both breaks the claim and is named
    both = [*rows, (1800.0, 45.0, 0.21, ok)]
    _, balance = weight_claims(sweep_points({"rfp-radius": both, "rfp-cone": rows}), forte_light, "5.3")
    assert not balance.reproduced and "both at weight 1800" in balance.cause
    # a failed trial is not enough force, whatever the plan's capacity
    trial_fails = [(60.0, 30.0, 0.19, sim(False)), (600.0, 45.0, 0.21, sim(True, True, False))]
    _, balance = weight_claims(sweep_points({"rfp-radius": trial_fails, "rfp-cone": rows}), forte_light, "5.3")
    assert balance.reproduced and "rfp-radius: never sufficient" in balance.ours
    # no rise in capacity: the weights do not shift the curves
    flat = [(60.0, 40.0, 0.16, ok), (600.0, 40.0, 0.16, ok)]
    shift, _ = weight_claims(sweep_points({"rfp-radius": flat, "rfp-cone": rows}), forte_light, "5.3")
    assert not shift.reproduced and "rfp-radius's mean capacity at weight 600" in shift.cause


def test_a_failed_sweep_plan_is_no_evidence():
    from forte.experiments.baseline_weights import SweepPoint, weight_claims
    ok = sim(True, True)
    points = sweep_points({"rfp-radius": [(60.0, 30.0, 0.19, ok)], "rfp-cone": [(60.0, 30.0, 0.19, ok)]})
    points.append(SweepPoint("rfp-cone", 600.0, fake_plan("rfp-cone", 20.0, mag=3.4),
                             fake_plan("rfp-cone", 60.0, success=False), ok))
    for claim in weight_claims(points, fake_plan("forte", 20.0, mag=3.4), "5.4"):
        assert not claim.reproduced and "rfp-cone@600: Maximum_Iterations_Exceeded" in claim.cause


def test_the_sweep_starts_from_the_authors_weight_of_each_set():
    from forte.experiments.baseline_weights import sweep_weights, with_capability_weight
    from forte.settings import WEIGHT_SETS
    for preset, base in (("forte-trajectory", 60.0), ("authors-trajectory", 60.0), ("authors-hold", 2.0)):
        weights = WEIGHT_SETS[preset].weights
        assert sweep_weights("rfp-cone", weights, (1.0, 10.0)) == (base, 10 * base)
        tuned = with_capability_weight("rfp-cone", 123.0, preset).resolve(weights)[0]
        assert tuned.capability == 123.0
        # the method's other tuning on that set is kept (the cone's joint-limit weight 2 on trajectories)
        assert tuned.joint_limits == (2.0 if preset != "authors-hold" else weights.joint_limits)


def test_the_hold_ball_is_judged_on_the_polytope_the_paper_draws():
    """``drawn_margin``: the ball's signed distance to P_r itself (alpha = 1, gravity residual at the held
    configuration), by hand from the Jacobian and Pinocchio's RNEA at rest."""
    from pathlib import Path

    from forte.experiments.hold_claims import drawn_margin
    from forte.planning.planner import plan
    from forte.planning.tasks.tasks import load_task

    task = load_task(Path(__file__).resolve().parents[1] / "examples" / "tasks" / "hold.yaml")
    res = plan(task, "teaching")
    q = res.q[0]
    J, g = task.robot.arm_jacobian(q), task.robot.rnea(q[3:], np.zeros(7), np.zeros(7))
    tm, f, r = task.robot.torque_limits, res.force.f[0], float(res.force.r[0])
    norms = np.linalg.norm(J, axis=0)
    by_hand = min(np.min((tm - g - J.T @ f) / norms), np.min((tm + g + J.T @ f) / norms)) - r
    assert drawn_margin(res) == pytest.approx(by_hand, abs=1e-9)
    # alpha < 1 only shrinks the polytope: the metric's d is below the drawn one
    assert float(res.metrics["d"][0]) < drawn_margin(res)


def test_projected_minor_axis_is_the_narrowest_width_of_the_shadow():
    """The xy / xz projection's minor semi-axis equals the smallest half-width of the shadow of
    {J qdot : |qdot| <= 1} over in-plane directions u, the support function max u.J qdot = |J^T u|
    (sampled over the angle), and a hand example."""
    from forte.experiments.hold_claims import projected_minor

    rng = np.random.default_rng(5)
    J = rng.normal(size=(3, 7)) * [[0.9], [0.5], [0.3]]
    res = SimpleNamespace(q=np.zeros((1, 10)), task=SimpleNamespace(robot=SimpleNamespace(arm_jacobian=lambda q: J)))
    theta = np.linspace(0, np.pi, 20001)
    for plane, (a, b) in (("xy", (0, 1)), ("xz", (0, 2))):
        u = np.zeros((3, theta.size))
        u[a], u[b] = np.cos(theta), np.sin(theta)
        widths = np.linalg.norm(J.T @ u, axis=0)
        assert projected_minor(res, plane) == pytest.approx(widths.min(), rel=1e-6)
    diag = np.zeros((3, 7))
    diag[0, 0], diag[1, 1], diag[2, 2] = 0.9, 0.4, 0.2
    res.task.robot.arm_jacobian = lambda q: diag
    assert projected_minor(res, "xy") == pytest.approx(0.4) and projected_minor(res, "xz") == pytest.approx(0.2)


def test_the_drawn_ellipsoid_adds_the_base_yaw_column():
    """``with_yaw``: the projection of the 3 x 8 ellipsoid (base yaw, then the arm), its Jacobian here
    by central differences of the end-effector position."""
    from forte.experiments.hold_claims import projected_minor
    from forte.model.robot import default_robot

    robot = default_robot()
    q = np.r_[0.3, -0.2, 0.4, 0.119, 0.925, -0.130, -0.620, 0.097, 1.560, 0.823]
    h = 1e-6
    cols = [(robot.ee_position(q + h * e) - robot.ee_position(q - h * e)) / (2 * h) for e in np.eye(10)[2:]]
    J8 = np.column_stack(cols)
    res = SimpleNamespace(q=q[None, :], task=SimpleNamespace(robot=robot))
    expected = np.sqrt(np.linalg.eigvalsh((J8 @ J8.T)[:2, :2])[0])
    assert projected_minor(res, "xy", with_yaw=True) == pytest.approx(expected, rel=1e-6)
    arm = J8[:, 1:]  # without the yaw column: the 3 x 7 arm ellipsoid's shadow
    assert projected_minor(res, "xy") == pytest.approx(np.sqrt(np.linalg.eigvalsh((arm @ arm.T)[:2, :2])[0]), rel=1e-6)
    assert J8[2, 0] == pytest.approx(0.0, abs=1e-8)  # the base's yaw moves the end effector horizontally only


def test_trials_default_to_the_paper_s_counts(tmp_path, monkeypatch):
    """Without --trials the CLI passes none, so each runner's default (the paper's count) applies."""
    import inspect

    from forte.experiments.continuous import run_continuous
    from forte.experiments.hold import run_hold
    from forte.experiments.lift import run_lift

    assert inspect.signature(run_continuous).parameters["trials"].default == 6  # Table: "6 per method"
    assert inspect.signature(run_lift).parameters["trials"].default == 3  # "the mean over three trials"
    assert inspect.signature(run_hold).parameters["trials"].default == 3
    parser, seen = recording_cli(monkeypatch, "run_continuous")
    args = parser.parse_args(["experiment", "continuous", "--out", str(tmp_path / "a"), "--quiet"])
    assert args.func(args) == 0 and "trials" not in seen
    args = parser.parse_args(["experiment", "continuous", "--out", str(tmp_path / "b"), "--quiet", "--trials", "2"])
    assert args.func(args) == 0 and seen["trials"] == 2
    args = parser.parse_args(["experiment", "continuous", "--out", str(tmp_path / "c"), "--trials", "-1"])
    assert args.func(args) == 2


def test_torque_limits_reach_the_runner_and_bad_values_are_one_line(tmp_path, monkeypatch, capsys):
    for runner, name in (("run_lift", "lift"), ("run_hold", "hold")):
        parser, seen = recording_cli(monkeypatch, runner)
        args = parser.parse_args(["experiment", name, "--out", str(tmp_path / name), "--torque-limits", "urdf",
                                  "--quiet"])
        assert args.func(args) == 0 and seen["torque_limits"] == "urdf"
    args = parser.parse_args(["experiment", "hold", "--out", str(tmp_path / "default"), "--quiet"])
    assert args.func(args) == 0 and "torque_limits" not in seen  # the runner's default, paper
    for name, value, expected in (("lift", "87", "expected one of paper, urdf, got '87'"),
                                  ("hold", "URDF", "expected one of paper, urdf"),
                                  ("continuous", "urdf", "only lift and hold take torque limits"),
                                  ("replan", "paper", "only lift and hold take torque limits")):
        out = tmp_path / f"bad-{name}"
        args = parser.parse_args(["experiment", name, "--out", str(out), "--torque-limits", value])
        assert args.func(args) == 2
        err = capsys.readouterr().err
        assert err.startswith("forte: error: --torque-limits: ") and expected in err and err.count("\n") == 1
        assert not out.exists()


def test_a_torque_limit_set_changes_the_task_robot_and_the_summary_names_it(tmp_path):
    from forte.model.description import PAPER_TORQUE_LIMITS, torque_limit_set
    from forte.model.presets import torque_limit_name, with_torque_limits
    from forte.planning.tasks.tasks import load_task

    task = load_task(common.task_path("hold"))
    assert common.with_limit_set(task, "paper") is task  # the task file's limits are the paper's
    urdf = common.with_limit_set(task, "urdf")
    assert urdf.robot.torque_limits.tolist() == [87.0] * 4 + [12.0] * 3
    assert urdf.robot.fingerprint != task.robot.fingerprint  # compiled kernels are not shared
    assert common.with_limit_set(urdf, "paper").robot.torque_limits.tolist() == list(PAPER_TORQUE_LIMITS)
    assert [torque_limit_name(r) for r in (task.robot, urdf.robot, with_torque_limits(task.robot, 50.0))] == [
        "paper", "urdf", "custom"]
    with pytest.raises(InvalidInputError, match="expected one of paper, urdf"):
        torque_limit_set("87/12")
    res = fake_plan("forte", 50.0)
    res.task = urdf
    doc = write_summary(tmp_path, "t", [], [Case("2.7 L", 2.7, {"forte": res})], [], [], {}, [])
    assert doc["settings"]["torque_limit_set"] == "urdf"
    assert doc["settings"]["torque_limits"] == [87.0] * 4 + [12.0] * 3
    assert ("Torque limits: `urdf`, 87/87/87/87/12/12/12 Nm (the URDF's efforts, a what-if; the paper uses 60/12)"
            in (tmp_path / "summary.md").read_text())


def test_an_rfp_baselines_shortfall_names_what_it_lacks():
    from forte.experiments.lift import _shortfall

    base = {"min_capacity": 52.1, "min_d": -2.0, "status": "infeasible", "verdict_failed": "capacity"}
    short = _shortfall({**base, "min_capacity_minus_force": -13.9, "min_capacity_margin": -23.9})
    assert "13.9 N short of |f| there" in short
    short = _shortfall({**base, "min_capacity_minus_force": 6.0, "min_capacity_margin": -4.0})
    assert "4.0 N short of |f| + r" in short
    text = _shortfall({**base, "min_capacity_minus_force": 13.9, "min_capacity_margin": 3.9})
    assert "3.9 N above |f| + r (min d = -2.0 N" in text and text.endswith("infeasible: capacity")
    assert "short" not in text


def test_manipulability_onlys_band_why_says_on_which_side_it_falls():
    from forte.experiments.hold_claims import band_why

    assert "below the band" in band_why(23.7, 37.7, 10.0) and "23.7 N < |f| − r = 27.7 N" in band_why(23.7, 37.7, 10.0)
    assert "above the band" in band_why(62.0, 37.7, 10.0) and "62.0 N >= |f| + r = 47.7 N" in band_why(62.0, 37.7, 10.0)
