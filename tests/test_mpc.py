"""forte as a model-predictive controller: ticks, asynchronous estimates, misses and failures, the CLI."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from forte.cli.main import main
from forte.exceptions import InvalidInputError
from forte.execution.mpc import MpcOptions
from forte.execution.run import simulate_plan

ROOT = Path(__file__).resolve().parents[1]
#: The first segment of the authors' lift (home to P1 in 5 s, 21 waypoints at 0.25 s), 0.35 kg;
#: IPOPT stops after 20 iterations (a plan needs 14, a re-plan for 200 kg more: a real failure).
SHORT_LIFT = """\
name: short-lift
mode: trajectory
path:
  kind: taught
  samples: 21
  configurations:
    - {t: 0.0, q: [0.0, 0.0, 0.0, 0.131, -0.104, -0.130, -1.864, 0.058, 1.779, 0.804]}
    - {t: 5.0, q: [0.138, 0.0017, -0.008, -0.053, 1.154, 0.010, -1.479, -0.079, 2.605, 0.828]}
payload:
  mass: 0.35
uncertainty_radius: 10.0
solver: {max_iter: 20}
"""


@pytest.fixture(scope="module")
def short_plan(tmp_path_factory):
    folder = tmp_path_factory.mktemp("mpc")
    (folder / "short.yaml").write_text(SHORT_LIFT)
    out = folder / "short"
    assert main(["plan", str(folder / "short.yaml"), "--out", str(out), "--quiet", "--no-figures"]) == 0
    return out


def _mpc(plan_dir: Path, **options) -> tuple[object, dict]:
    result = simulate_plan(plan_dir, hold=0.2, write=False, mpc=MpcOptions(**options))
    return result, result.summary["mpc"]


@pytest.mark.parametrize("options, field", [
    ({"rate_hz": 0}, "rate_hz"), ({"rate_hz": -5}, "rate_hz"), ({"rate_hz": float("nan")}, "rate_hz"),
    ({"rate_hz": 2000}, "rate_hz"), ({"deadline_s": 0}, "deadline_s"), ({"on_miss": "later"}, "on_miss"),
    ({"threshold": -1}, "threshold"), ({"add_mass": (1.0, -2.0)}, "add_mass"),
    ({"estimates": ((0.8, 0.0),)}, "estimates"), ({"estimates": ((-1, 2.7),)}, "estimates"),
    ({"source": 3}, "source"), ({"start": "planned"}, "start"), ({"on_infeasible": "slow"}, "on_infeasible"),
])
def test_bad_options_are_one_line_errors(options, field):
    with pytest.raises(InvalidInputError, match=f"^{field}: expected") as info:
        MpcOptions(**options)
    assert "\n" not in str(info.value)


def test_bad_rate_exits_2_through_the_cli(short_plan, capsys):
    assert main(["simulate", str(short_plan), "--mpc", "0"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and err.startswith("forte: error: --mpc: expected a rate in (0, 1000]"), err
    assert main(["simulate", str(short_plan), "--mpc", "100", "--replan"]) == 2
    assert main(["simulate", str(short_plan), "--estimate-at", "0.8:2.7"]) == 2  # without --mpc
    assert main(["simulate", str(short_plan), "--mpc-start", "rest"]) == 2  # without --mpc
    assert main(["simulate", str(short_plan), "--mpc", "100", "--estimate-at", "soon"]) == 2
    assert "--mpc" in capsys.readouterr().err
    assert main(["simulate", str(short_plan), "--on-infeasible", "keep"]) == 2  # without --replan or --mpc
    assert capsys.readouterr().err.strip() == "forte: error: --on-infeasible: applies to --replan and --mpc runs only"


def test_an_async_estimate_is_applied_at_the_first_tick_at_or_after_its_time(short_plan):
    # 30 Hz: ticks every 33 ms, at 0.792 s and 0.825 s around the estimate's 0.8 s
    polled = []

    def source(t: float) -> float | None:  # e.g. draining a queue that a VLM thread fills
        polled.append(t)
        return 1.5 if len(polled) == 50 else None

    # a deadline no solve misses: what is published here does not depend on the machine's speed
    _, mpc = _mpc(short_plan, rate_hz=30, deadline_s=10.0, identify=False, estimates=((0.8, 2.7),), source=source,
                  solver="converged")  # a converged solve publishes the new mass at once (a real-time step may not)
    log = mpc["log"]
    before = [e for e in log if e["t"] < 0.8]
    first = next(e for e in log if e["t"] >= 0.8)
    assert before and all(e["mass"] == 0.35 for e in before)
    assert first["t"] == pytest.approx(0.825) and first["mass"] == 2.7
    assert first["kind"] == "resolve" and first["published"] and first["planned_mass"] == 2.7
    assert mpc["async_estimates"][0] == {"t": 0.8, "mass": 2.7, "applied_t": first["t"]}
    polled_tick = log[49]
    assert polled_tick["t"] == pytest.approx(polled[49]) and polled_tick["mass"] == 1.5
    assert all(e["mass"] == 2.7 for e in log[25:49]) and all(e["mass"] == 1.5 for e in log[49:])
    assert mpc["ticks"] == len(polled) == len(log)


def test_a_failed_solve_is_never_published_and_is_counted(short_plan):
    # 200 kg needs more than the task's 20 IPOPT iterations from the 0.35 kg solution (and cold)
    _, mpc = _mpc(short_plan, identify=False, estimates=((0.5, 200.0),), solver="converged", backend="ipopt")
    log = mpc["log"]
    failed = [i for i, e in enumerate(log) if e["kind"] is not None and not e["solved"]]
    assert failed and mpc["failed"] == len(failed)
    for i in failed:
        assert not log[i]["published"] and log[i]["planned_mass"] == log[i - 1]["planned_mass"]
    assert log[failed[0]]["t"] == 0.5 and log[failed[0]]["planned_mass"] == 0.35
    # the same failed problem is not tried again: one attempt per waypoint while it fails
    attempts = [e["t"] for e in log if e["kind"] is not None and e["t"] < 1.0]
    assert sum(0.5 <= t < 0.75 for t in attempts) == 1


def test_a_solve_over_its_deadline_is_not_published_and_is_counted(short_plan):
    result, mpc = _mpc(short_plan, rate_hz=20, deadline_s=1e-6)
    assert mpc["solves"] > 0 and mpc["misses"] == mpc["solves"] and mpc["published"] == 0
    assert all(e["planned_mass"] == 0.35 and not e["published"] for e in mpc["log"])
    open_loop = simulate_plan(short_plan, hold=0.2, write=False)
    # nothing was published: the controller followed the original plan
    assert np.max(np.abs(result.log["q2"] - open_loop.log["q2"])) < 1e-9
    _, delayed = _mpc(short_plan, rate_hz=20, deadline_s=1e-6, on_miss="delay")
    assert delayed["misses"] == delayed["solves"] > 0
    assert delayed["published"] >= delayed["solves"] - delayed["failed"] - 1 > 0  # the last may end the run


def test_mpc_follows_the_plan_and_reports_its_ticks(short_plan, capsys):
    out = short_plan.parent / "mpc-run"
    code = main(["simulate", str(short_plan), "--mpc", "100", "--deadline", "10", "--hold", "0.2", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 0, err
    doc = json.loads((out / "sim.json").read_text())
    mpc = doc["mpc"]
    assert doc["verdict"] == "success" and doc["max_ee_error_m"] < 0.02
    assert mpc["ticks"] == 521 and mpc["tick_period_s"] == pytest.approx(0.01)  # 5.2 s at 100 Hz
    shifts = [e for e in mpc["log"] if e["kind"] == "shift"]
    assert [e["t"] for e in shifts] == pytest.approx(0.25 * np.arange(1, 20))  # every waypoint but the last
    assert mpc["misses"] == 0 and mpc["failed"] == 0 and mpc["published"] == mpc["solves"]
    assert mpc["solve_median_s"] <= mpc["solve_p95_s"] <= mpc["solve_max_s"]
    assert abs(mpc["final_mass_estimate"] - 0.35) < 0.01 and mpc["min_d"] > 0
    assert "MPC at 100 Hz (real-time iterations): 521 ticks" in err and "over the 10000 ms deadline" in err


@pytest.mark.slow
def test_the_experiment_carries_the_misjudged_lift_under_mpc_that_fails_open_loop(tmp_path):
    from forte.experiments import run_mpc
    from forte.experiments.mpc import SCENARIOS

    misjudged = next(iter(SCENARIOS))
    doc = run_mpc(tmp_path / "mpc", scenarios=(misjudged,), modes=("open loop", "MPC 100 Hz, real-time iterations"),
                  trials=1)
    runs = doc["runs"][misjudged]
    assert not runs["open loop"]["success"] and runs["open loop"]["reason"] == "torque saturation"
    mpc = runs["MPC 100 Hz, real-time iterations"]
    assert mpc["success"], mpc["detail"]
    assert mpc["mpc"]["ticks"] == 1101 and mpc["mpc"]["published"] > 0 and mpc["mpc"]["solver"] == "rti"
    assert abs(mpc["mpc"]["final_mass_estimate"] - 2.7) < 0.01
    assert (tmp_path / "mpc" / "mpc.png").is_file() and doc["generator"] == "forte"
    text = (tmp_path / "mpc" / "summary.md").read_text()
    assert "| scenario | mode |" in text and "fails with 'open loop'" in text and "| success | 1 of 1 |" in text
    with pytest.raises(InvalidInputError, match="scenarios: unknown"):
        run_mpc(tmp_path / "other", scenarios=("sideways",))


def test_real_time_iterations_carry_a_misjudged_payload_and_never_publish_an_unsound_step(short_plan):
    """One Newton step per tick after the payload turns out 2.7 kg: the steps right after the jump
    leave pose errors above the tolerance (not published, the plan in force stays), later ones are
    published; every step is a real-time iteration (0 or 1 Newton steps)."""
    result, mpc = _mpc(short_plan, deadline_s=10.0, identify=False, estimates=((0.3, 2.7),))
    log = mpc["log"]
    steps = [e for e in log if e["kind"] is not None]
    unsound = [i for i, e in enumerate(log) if e["kind"] is not None and not e["solved"]]
    assert unsound and mpc["failed"] == len(unsound) and all(log[i]["reason"] == "violation" for i in unsound)
    for i in unsound:
        assert not log[i]["published"] and log[i]["planned_mass"] == log[i - 1]["planned_mass"]
    assert any(e["published"] and e["planned_mass"] == 2.7 for e in steps)
    assert all(e["iterations"] in (0, 1) for e in steps) and mpc["solver"] == "rti"
    assert result.success, result.detail


@pytest.mark.parametrize("start", ["reference", "measured"])
def test_a_shift_starts_moving_as_the_reference_does(short_plan, monkeypatch, start):
    """Each shift hands the re-planner the measured configuration ``q_j`` and the motion the
    reference executes there: the backward differences of the waypoints it passes through, the
    plan in force's ``q_{j-2}, q_{j-1}`` then ``q_j`` (``v = (q_j - q_{j-1}) / dt``,
    ``a = (v - (q_{j-1} - q_{j-2}) / dt) / dt``; the plan starts at rest), computed here from the
    loop's plan in force. ``start="measured"`` hands the measured velocity instead, which is not
    that motion (the step itself runs unchanged)."""
    from forte.execution.mpc import MpcLoop
    from forte.planning.online.realtime import RealTimeIteration

    loops, seen = [], []
    real_init, real_step = MpcLoop.__post_init__, RealTimeIteration.step

    def recording_init(self):
        real_init(self)
        loops.append(self)

    def recording_step(self, *args, **kwargs):
        if kwargs.get("steps"):
            loop = loops[-1]
            j = loop.horizon + kwargs["steps"]  # the waypoint the horizon shifts to
            q, t = loop.plan_q, loop.plan_t  # the plan in force, before the splice
            v = (kwargs["q_now"] - q[j - 1]) / (t[j] - t[j - 1])
            v_before = (q[j - 1] - q[j - 2]) / (t[j - 1] - t[j - 2]) if j >= 2 else np.zeros_like(v)
            out = real_step(self, *args, **kwargs)
            used = self.replanner.task.start_motion
            seen.append((v, (v - v_before) / (t[j] - t[j - 1]), used.velocity, used.acceleration))
            return out
        return real_step(self, *args, **kwargs)

    monkeypatch.setattr(MpcLoop, "__post_init__", recording_init)
    monkeypatch.setattr(RealTimeIteration, "step", recording_step)
    result, mpc = _mpc(short_plan, deadline_s=10.0, start=start)
    assert result.success and len(seen) == 19  # every waypoint but the last
    assert max(np.abs(v[3:]).max() for v, *_ in seen) > 0.05  # mid-motion: the arm moves
    velocity_gap = max(np.abs(used_v - v).max() for v, _, used_v, _ in seen)
    if start == "reference":
        assert velocity_gap < 1e-9
        for _, a, _, used_a in seen:
            np.testing.assert_allclose(used_a, a, atol=1e-9)
    else:
        assert velocity_gap > 1e-3, velocity_gap  # the measured velocity is not the reference's motion
