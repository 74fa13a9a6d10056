"""Exports of a plan and of the robot model, one owner per format.

Plans (:func:`export_plan`, format from the file suffix):

- ``.npz``: ``t``, ``q``, ``qd``, ``qdd`` (N x nq), ``joint_names``, the units of each, the task
  force (``force_t``, ``force_f``, ``force_r``), every column of ``metrics.csv`` as
  ``metric_<name>`` and the plan's ``method`` / ``status``;
- ``.csv``: one row per waypoint, columns ``t``, ``<joint>``, ``<joint>.velocity``,
  ``<joint>.acceleration``; comment lines (``#``) above the header give the plan and the unit of
  every column;
- ``.mcap``: ROS 2 topics (CDR, ``ros2msg`` schemas), written with ``mcap-ros2-support``; ``ros2 bag``
  (rosbag2's MCAP storage) and Foxglove read it: the ``trajectory_msgs/JointTrajectory``, the
  robot description (``package://`` meshes, as ``forte robot export`` writes it), ``/tf_static`` and
  ``/tf``, ``/joint_states``, the force and RFP markers and the scene's bodies, each topic with the
  QoS ``ros2 bag play`` offers it with (:mod:`forte.io.mcap_export`).

Velocities and accelerations are the plan's own: the backward differences from rest the planner
optimizes (:func:`forte.model.trajectory.backward_differences`), ``v_k = (q_k - q_{k-1}) / dt``,
``a_k = (v_k - v_{k-1}) / dt``, ``v_1 = a_1 = 0``.

Joints are named as in the whole-body model (:func:`forte.io.whole_body.whole_body_urdf`):
``base_x``, ``base_y`` (prismatic, m), ``base_yaw`` (revolute, rad) and the arm joints of the URDF.

The robot: :func:`~forte.io.whole_body.whole_body_urdf` is the arm's URDF mounted on the three
base joints (the MJCF of the simulation model is :func:`forte.execution.model.whole_body_mjcf`;
``forte robot export`` writes either).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from forte.exceptions import InvalidInputError, OutputError
from forte.io.mcap_export import write_mcap
from forte.io.plandir import read_metrics, read_plan_dir
from forte.io.whole_body import BASE_JOINTS as BASE_JOINTS  # owned there, kept importable here
from forte.io.whole_body import BASE_LINKS as BASE_LINKS
from forte.io.whole_body import BASE_RANGE as BASE_RANGE
from forte.io.whole_body import portable_urdf as portable_urdf
from forte.io.whole_body import whole_body_urdf as whole_body_urdf
from forte.model.robot import MobileManipulator
from forte.model.scene import Scene
from forte.model.trajectory import backward_differences
from forte.validation import FloatArray

PLAN_FORMATS = (".npz", ".csv", ".mcap")


@dataclass
class ExportedPlan:
    """What every plan export holds (arrays N x nq, times N)."""

    method: str
    status: str
    t: FloatArray
    q: FloatArray
    qd: FloatArray
    qdd: FloatArray
    joint_names: tuple[str, ...]
    units: tuple[str, ...]  # position unit per joint: m or rad
    force: dict[str, FloatArray] = field(default_factory=dict)  # t, f, r
    metrics: dict[str, FloatArray] = field(default_factory=dict)
    robot: MobileManipulator | None = None  # the plan's robot (the MCAP's description and transforms)
    scene: Scene = field(default_factory=Scene)  # the bodies the plan avoided (the MCAP's scene markers)

    @property
    def velocity_units(self) -> tuple[str, ...]:
        return tuple(f"{u}/s" for u in self.units)

    @property
    def acceleration_units(self) -> tuple[str, ...]:
        return tuple(f"{u}/s^2" for u in self.units)


def joint_names(robot: MobileManipulator) -> tuple[str, ...]:
    """Whole-body joint names: :data:`BASE_JOINTS` and the arm joints."""
    return (*BASE_JOINTS, *(robot.arm_joints or ()))


def joint_units(robot: MobileManipulator) -> tuple[str, ...]:
    """Position unit of each whole-body joint (``m`` for prismatic, ``rad`` for revolute)."""
    arm = []
    for j in range(1, robot.model.njoints):
        kind = robot.model.joints[j].shortname()
        arm.append("m" if "JointModelP" in kind else "rad")
    return ("m", "m", "rad", *arm)


def plan_data(plan_dir: str | Path) -> ExportedPlan:
    """Read a plan directory and add the plan's velocities and accelerations."""
    plan = read_plan_dir(plan_dir)
    qd, qdd = backward_differences(plan.q, plan.t, "q")
    force = {} if plan.force is None else {"t": plan.force.t, "f": plan.force.f, "r": plan.force.r}
    return ExportedPlan(method=plan.method, status=plan.status, t=plan.t, q=plan.q, qd=qd, qdd=qdd,
                        joint_names=joint_names(plan.robot), units=joint_units(plan.robot), force=force,
                        metrics=read_metrics(plan_dir), robot=plan.robot, scene=plan.scene)


def export_plan(plan_dir: str | Path, path: str | Path) -> Path:
    """Write the plan in ``plan_dir`` to ``path``; the format is the suffix (:data:`PLAN_FORMATS`)."""
    path = Path(path)
    writers = {".npz": write_npz, ".csv": write_csv_export, ".mcap": write_mcap}
    suffix = path.suffix.lower()
    if suffix not in writers:
        raise InvalidInputError(f"{path}: unknown export format {path.suffix or '(no suffix)'}; expected one of "
                                f"{', '.join(PLAN_FORMATS)}")
    _check_target(path)
    data = plan_data(plan_dir)
    writers[suffix](data, path)
    return path


def _check_target(path: Path) -> None:
    if path.is_dir():
        raise OutputError(f"{path}: is a directory; expected a file name")
    if not path.parent.is_dir():
        raise OutputError(f"{path}: folder {path.parent} does not exist")


def write_npz(data: ExportedPlan, path: Path) -> None:
    """The ``.npz`` export (see the module docstring)."""
    arrays: dict[str, Any] = {
        "t": data.t, "q": data.q, "qd": data.qd, "qdd": data.qdd,
        "joint_names": np.array(data.joint_names), "position_units": np.array(data.units),
        "velocity_units": np.array(data.velocity_units), "acceleration_units": np.array(data.acceleration_units),
        "time_unit": np.array("s"), "method": np.array(data.method), "status": np.array(data.status),
    }
    if data.force:
        arrays |= {"force_t": data.force["t"], "force_f": data.force["f"], "force_r": data.force["r"],
                   "force_unit": np.array("N")}
    arrays |= {f"metric_{name}": values for name, values in data.metrics.items()}
    with open(path, "wb") as fh:  # np.savez would append .npz to any other name
        np.savez(fh, **arrays)


def csv_columns(data: ExportedPlan) -> tuple[list[str], list[str]]:
    """Column names and units of the ``.csv`` export."""
    names = ["t", *data.joint_names, *(f"{j}.velocity" for j in data.joint_names),
             *(f"{j}.acceleration" for j in data.joint_names)]
    units = ["s", *data.units, *data.velocity_units, *data.acceleration_units]
    return names, units


def write_csv_export(data: ExportedPlan, path: Path) -> None:
    """The ``.csv`` export: ``#`` comment lines (plan, units), a header and one row per waypoint."""
    names, units = csv_columns(data)
    rows = np.column_stack([data.t, data.q, data.qd, data.qdd])
    lines = [f"# forte plan export: method {data.method}, status {data.status}; velocities and accelerations "
             "are backward differences from rest",
             "# units: " + ",".join(units), ",".join(names)]
    lines += [",".join(repr(float(v)) for v in row) for row in rows]
    path.write_text("\n".join(lines) + "\n")
