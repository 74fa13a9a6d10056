"""``forte view --save``: the Rerun recording is read back with rerun's own reader and checked."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rerun")

from rerun.chunk import RrdReader  # noqa: E402

from forte.capability.polytope import trajectory_rfp  # noqa: E402
from forte.cli.main import main  # noqa: E402
from forte.io.plandir import read_metrics, read_plan_dir, write_plan  # noqa: E402
from forte.planning.planner import plan  # noqa: E402
from forte.planning.tasks.tasks import load_task  # noqa: E402

LIFT = Path(__file__).resolve().parents[1] / "examples" / "tasks" / "lift.yaml"


def _columns(path: Path) -> dict[str, dict[str, list]]:
    """Entity path -> column name -> values over all of its chunks (timeline order)."""
    out: dict[str, dict[str, list]] = {}
    for chunk in RrdReader(path).stream():
        cols = out.setdefault(chunk.entity_path, {})
        batch = chunk.to_record_batch()
        for name in batch.schema.names:
            if name == "log_time":  # wall-clock time stamps
                continue
            column = batch.column(name)
            if name == "time":  # a duration in ns
                column = column.cast("int64")
            cols.setdefault(name, []).extend(column.to_pylist())
    return out


def test_recording_reopens_with_robot_force_rfp_and_plots(tmp_path: Path) -> None:
    plan_dir = write_plan(plan(load_task(LIFT, waypoints=8), "quintic"), tmp_path / "lift", figures=False)
    out = tmp_path / "lift.rrd"
    assert main(["view", str(plan_dir), "--save", str(out), "--quiet"]) == 0
    data = _columns(out)
    ref, metrics = read_plan_dir(plan_dir), read_metrics(plan_dir)
    n = len(ref.t)
    meshes = [e for e in data if e.startswith("/world/robot/") and e.endswith("/mesh")]
    assert len(meshes) >= 9  # Panda links 0-7 and the hand
    assert all(any(b for b in data[e]["Asset3D:blob"]) for e in meshes)  # the mesh files are embedded
    poses = data[meshes[0].removesuffix("/mesh")]
    np.testing.assert_allclose(np.array(poses["time"], dtype=float) / 1e9,
                               ref.t - ref.t[0], atol=1e-9)
    ball = data["/force_space/ball"]
    np.testing.assert_allclose(np.array([c[0] for c in ball["Ellipsoids3D:centers"]]), ref.force.f, rtol=1e-6)
    np.testing.assert_allclose([h[0][0] for h in ball["Ellipsoids3D:half_sizes"]], ref.force.r, rtol=1e-6)
    rfp = trajectory_rfp(ref.robot, ref.q, ref.t).at(3)
    logged = np.array(data["/force_space/rfp"]["Mesh3D:vertex_positions"][3])
    np.testing.assert_allclose(logged, rfp.vertices, rtol=1e-5, atol=1e-3)
    capacity = [v[0] for v in data["/plots/capacity/capacity"]["Scalars:scalars"] if v is not None]
    np.testing.assert_allclose(capacity, metrics["directional_capacity"], rtol=1e-6)
    assert len(data["/plots/manipulability"]["Scalars:scalars"]) >= n
    assert "/world/ee_path" in data and "/world/base_path" in data


def test_view_errors(tmp_path: Path, capsys: pytest.CaptureFixture, monkeypatch: pytest.MonkeyPatch) -> None:
    assert main(["view", str(tmp_path / "nothing"), "--save", str(tmp_path / "x.rrd")]) == 2
    assert main(["view", str(tmp_path), "--save", str(tmp_path / "x.mp4")]) == 2
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    assert main(["view", str(tmp_path)]) == 2
    assert "--save FILE.rrd" in capsys.readouterr().err.splitlines()[-1]
