"""The paper's claims on the lifting task (Section 5.3), on the authors' lift (N = 41).

Where our model does not reproduce a claim the test is an ``xfail(strict=True)`` with the reason,
so the day it starts to hold, the suite says so.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from forte.planning.planner import plan
from forte.planning.tasks import load_task

LIFT = Path(__file__).resolve().parents[1] / "examples" / "tasks" / "lift.yaml"
N = 41  # the authors' lift: 10 s, dt = 0.25 s


@pytest.fixture(scope="module")
def heavy():
    task = load_task(LIFT, mass=2.7, waypoints=N)
    return {m: plan(task, m) for m in ("forte", "quintic")}


@pytest.fixture(scope="module")
def light():
    task = load_task(LIFT, mass=0.35, waypoints=N)
    return {m: plan(task, m) for m in ("forte", "manipulability", "rfp-radius")}


@pytest.mark.xfail(strict=True, reason="with the authors' trajectory weights (capability 1 against "
                   "manipulability 1, joint limits 8, velocity 10, smoothness 8 summed over 41 waypoints) forte's "
                   "optimum keeps capacity - (|f| + r) about 11 N short near P1 (measured: -11.2 N at 2.8 kg); "
                   "see the issue note")
def test_forte_keeps_capacity_above_the_force_band_with_2p7_litres(heavy):
    res = heavy["forte"]
    assert res.success
    assert np.all(res.metrics["directional_capacity"] >= res.force.magnitude + res.force.r)


def test_quintic_baseline_lacks_capacity_with_2p7_litres(heavy):
    res = heavy["quintic"]
    assert np.any(res.metrics["directional_capacity"] < res.force.magnitude + res.force.r)


def test_forte_manipulability_close_to_the_manipulability_baseline_with_0p33_litres(light):
    ours = light["forte"].metrics["manipulability"].mean()
    best = light["manipulability"].metrics["manipulability"].mean()
    assert light["forte"].success and light["manipulability"].success
    assert ours >= 0.9 * best


def test_rfp_radius_gives_up_manipulability_with_0p33_litres(light):
    assert light["rfp-radius"].metrics["manipulability"].mean() < light["forte"].metrics["manipulability"].mean()
