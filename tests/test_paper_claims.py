"""The paper's claims on the lifting task (Section 5.3), at a small horizon.

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
N = 30


@pytest.fixture(scope="module")
def heavy():
    task = load_task(LIFT, mass=2.7, waypoints=N)
    return {m: plan(task, m) for m in ("forte", "quintic")}


@pytest.fixture(scope="module")
def light():
    task = load_task(LIFT, mass=0.35, waypoints=N)
    return {m: plan(task, m) for m in ("forte", "manipulability", "rfp-radius")}


def test_forte_keeps_capacity_above_the_force_band_with_2p7_litres(heavy):
    res = heavy["forte"]
    assert res.success
    assert np.all(res.metrics["directional_capacity"] >= res.force.magnitude + res.force.r)


@pytest.mark.xfail(strict=True, reason="in our model the IK path stays near the Panda's strong home "
                   "posture, so the quintic baseline keeps a large margin (see the issue note)")
def test_quintic_baseline_lacks_capacity_with_2p7_litres(heavy):
    res = heavy["quintic"]
    assert np.any(res.metrics["directional_capacity"] < res.force.magnitude + res.force.r)


def test_forte_manipulability_close_to_the_manipulability_baseline_with_0p33_litres(light):
    ours = light["forte"].metrics["manipulability"].mean()
    best = light["manipulability"].metrics["manipulability"].mean()
    assert light["forte"].success and light["manipulability"].success
    assert ours >= 0.9 * best


@pytest.mark.xfail(strict=True, reason="with the authors' weights the 1/radius term (~0.03 per N) is "
                   "too small against 1/manipulability, so rfp-radius behaves like the manipulability "
                   "baseline in our model (see the issue note)")
def test_rfp_radius_gives_up_manipulability_with_0p33_litres(light):
    assert light["rfp-radius"].metrics["manipulability"].mean() < light["forte"].metrics["manipulability"].mean()
