"""The paper's claims on the lifting task (Section 5.3), on the authors' lift (N = 41), with
forte's default weights (``forte-trajectory``: the authors' set with capability weight 5).

Where our model does not reproduce a claim the test is an ``xfail(strict=True)`` with the reason,
so the day it starts to hold, the suite says so.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from forte.execution.run import simulate_plan
from forte.io.plandir import write_plan
from forte.planning.planner import plan
from forte.planning.tasks.tasks import load_task
from forte.settings import WEIGHT_SETS

LIFT = Path(__file__).resolve().parents[1] / "examples" / "tasks" / "lift.yaml"
N = 41  # the authors' lift: 10 s, dt = 0.25 s


@pytest.fixture(scope="module")
def heavy():
    task = load_task(LIFT, mass=2.8, waypoints=N)  # the 2.7 L pack plus 0.1 kg
    return {m: plan(task, m) for m in ("forte", "quintic")}


@pytest.fixture(scope="module")
def light():
    task = load_task(LIFT, mass=0.35, waypoints=N)
    return {m: plan(task, m) for m in ("forte", "manipulability", "rfp-radius")}


def test_forte_keeps_capacity_above_the_force_band_with_2p7_litres(heavy):
    res = heavy["forte"]
    assert res.success
    assert np.all(res.metrics["directional_capacity"] >= res.force.magnitude + res.force.r)


def test_authors_exact_weights_fall_short_under_the_heavy_load():
    # Why forte's default departs from the authors' set (README, Weights): with capability 1 the
    # same plan keeps capacity - (|f| + r) more than 5 N short (8.2 N with the authors' 3 x 8
    # manipulability; 10.9 N with the 3 x 7 one the set used before issue 27).
    task = load_task(LIFT, mass=2.8, waypoints=N)
    exact = plan(task.with_weights(WEIGHT_SETS["authors-trajectory"]), "forte")
    assert exact.solved and not exact.feasible
    assert np.min(exact.metrics["directional_capacity"] - exact.force.magnitude - exact.force.r) < -5


def test_quintic_baseline_lacks_capacity_with_2p7_litres(heavy):
    res = heavy["quintic"]
    assert np.any(res.metrics["directional_capacity"] < res.force.magnitude)


def test_every_forte_lift_plan_ends_at_rest(heavy, light):
    for res in (heavy["forte"], light["forte"]):
        dq = np.diff(res.q, axis=0) / np.diff(res.t)[:, None]
        assert np.abs(dq[-1]).max() < 1e-6 and np.abs(dq[-2]).max() < 1e-6


@pytest.mark.slow
def test_in_mujoco_forte_lifts_2p8_kg_and_quintic_does_not(heavy, tmp_path):
    runs = {m: simulate_plan(write_plan(res, tmp_path / m, figures=False), write=False)
            for m, res in heavy.items()}
    assert runs["forte"].success, runs["forte"].detail
    assert not runs["quintic"].success
    # ... and quintic's failure is the load's: without the payload it tracks
    assert simulate_plan(tmp_path / "quintic", 0.0, write=False).success


def test_forte_manipulability_close_to_the_manipulability_baseline_with_0p33_litres(light):
    ours = light["forte"].metrics["manipulability"].mean()
    best = light["manipulability"].metrics["manipulability"].mean()
    assert light["forte"].feasible and light["manipulability"].solved
    assert ours >= 0.9 * best


def test_rfp_radius_gives_up_manipulability_with_0p33_litres(light):
    assert light["rfp-radius"].metrics["manipulability"].mean() < light["forte"].metrics["manipulability"].mean()


@pytest.mark.slow
def test_forte_2p7_litre_lift_holds_over_the_mass_range_the_ball_covers(tmp_path):
    # r = 10 N is meant to cover the payload's uncertainty: +-10 % of 2.7 kg
    res = plan(load_task(LIFT, mass=2.7, waypoints=N), "forte")
    plan_dir = write_plan(res, tmp_path / "forte", figures=False)
    for mass in (2.43, 2.7, 2.97):
        run = simulate_plan(plan_dir, mass, write=False)
        assert run.success, f"{mass} kg: {run.detail}"
        assert max(run.summary["max_torque_ratio"]) < 1.0


def test_forte_keeps_the_ball_inside_the_polytope_when_holding_2p7_litres():
    """Section 5.4: forte's held configuration keeps the 10 N ball inside the RFP, on the metric's
    alpha-scaled polytope (d >= 0) and on the unscaled one the paper draws; a centred surrogate
    (knee 0, half the kink's slope at d = 0) stops nearer the edge (measured: d = -0.002 N)."""
    from forte.experiments.hold_claims import drawn_margin

    task = load_task(LIFT.parent / "hold.yaml")  # 2.7 kg
    res = plan(task, "forte")
    assert res.success and float(res.metrics["d"][0]) >= 0 and drawn_margin(res) >= 0
    res0 = plan(replace(task, settings=task.settings.with_values("capability", knee=0.0)), "forte")
    assert res0.success and float(res0.metrics["d"][0]) < float(res.metrics["d"][0])
