"""The arm's self-collision pairs: which SRDF leaves pairs out, and what a self-collision names."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest

from forte.force.taskforce import given_force
from forte.model.description import example_robot_data_dir
from forte.model.presets import preset_robot
from forte.model.robot import N_BASE, MobileManipulator
from forte.model.self_collision import BROAD_PHASE_MARGIN, ArmGeometry, arm_geometry, locked_key, package_srdf
from forte.planning.verdict.motion_samples import sample_motion
from forte.planning.verdict.verdict import judge

TIAGO_JOINTS = ("torso_lift_joint", *(f"arm_{i}_joint" for i in range(1, 8)))
#: The raw TIAGo's start posture of issue 36 (arm joints; the first the torso lift, m).
TIAGO_START = np.array([0.15, 0.2, -1.34, -0.2, 1.94, -1.57, 1.37, 0.0])
#: A posture near it whose first colliding pair in the geometry's order (the column with
#: arm_4_link, 0.4 mm) is not its deepest (the column with the hand's safety box, ~5 cm).
TIAGO_TUCKED = np.array([0.15, 0.356, -1.359, 0.005, 1.84, -1.517, 1.414, 0.014])


def _erd(path: str) -> Path:
    return example_robot_data_dir() / path


@pytest.fixture(scope="module")
def tiago():
    return MobileManipulator(urdf="erd:tiago_description/robots/tiago.urdf", ee_frame="arm_tool_link",
                             arm_joints=TIAGO_JOINTS, base="differential")


@pytest.mark.parametrize(("urdf", "srdf"), [
    ("kinova_description/robots/kinova.urdf", "kinova_description/srdf/kinova.srdf"),  # robots/ + srdf/
    ("panda_description/urdf/panda.urdf", "panda_description/srdf/panda.srdf"),  # the URDF's stem
    ("panda_description/urdf/panda_collision.urdf", "panda_description/srdf/panda.srdf"),  # its robot's name
    ("ur_description/urdf/ur5_robot.urdf", "ur_description/srdf/ur5.srdf"),  # not ur3_gripper.srdf, sorted first
    ("ur_description/urdf/ur5_joint_limited_robot.urdf", "ur_description/srdf/ur5_joint_limited_robot.srdf"),
    ("tiago_description/robots/tiago.urdf", None),  # the package has no SRDF
])
def test_the_srdf_is_the_packages_own_named_after_the_urdf_or_its_robot(urdf, srdf):
    assert package_srdf(_erd(urdf)) == (None if srdf is None else _erd(srdf))


def test_an_srdf_is_found_beside_the_urdf_or_in_the_packages_srdf_folder_and_nowhere_else(tmp_path):
    kinova = _erd("kinova_description/robots/kinova.urdf")
    alone = tmp_path / "alone" / "kinova.urdf"
    alone.parent.mkdir()
    shutil.copy(kinova, alone)
    assert package_srdf(alone) is None
    shutil.copy(_erd("kinova_description/srdf/kinova.srdf"), tmp_path / "alone" / "kinova.srdf")
    assert package_srdf(alone) == tmp_path / "alone" / "kinova.srdf"
    package = tmp_path / "pkg"
    (package / "description").mkdir(parents=True)
    (package / "srdf").mkdir()
    shutil.copy(kinova, package / "description" / "arm.urdf")  # another stem: found by the robot's name
    shutil.copy(_erd("kinova_description/srdf/kinova.srdf"), package / "srdf" / "kinova.srdf")
    shutil.copy(_erd("panda_description/srdf/panda.srdf"), package / "srdf" / "another.srdf")
    assert package_srdf(package / "description" / "arm.urdf") == package / "srdf" / "kinova.srdf"


def test_the_panda_leaves_out_exactly_its_srdfs_pairs_and_adjacent_links_and_records_them():
    urdf, srdf = _erd("panda_description/urdf/panda.urdf"), _erd("panda_description/srdf/panda.srdf")
    joints = tuple(f"panda_joint{i}" for i in range(1, 8))
    geometry = ArmGeometry(urdf, joints)
    text = srdf.read_text()
    disabled = {frozenset(m) for m in re.findall(r'disable_collisions link1="([^"]+)" link2="([^"]+)"', text)}
    objs, parents = geometry.geom.geometryObjects, geometry.model.parents
    checked = set()
    for pair in geometry.geom.collisionPairs:
        a, b = objs[pair.first], objs[pair.second]
        links = frozenset((a.name.rsplit("_", 1)[0], b.name.rsplit("_", 1)[0]))
        assert links not in disabled
        ja, jb = a.parentJoint, b.parentJoint
        assert ja != jb and parents[ja] != jb and parents[jb] != ja
        checked.add(links)
    record = geometry.record()
    reasons = {r: text.count(f'reason="{r}"') for r in ("Adjacent", "Never", "Default")}
    assert record == {"srdf": "erd:panda_description/srdf/panda.srdf", "srdf_disabled": reasons,
                      "adjacent_links_excluded": True, "pairs_checked": len(geometry.geom.collisionPairs)}
    assert sum(reasons.values()) == len(disabled) and len(checked) > 0


def test_the_raw_tiago_records_that_no_srdf_was_found(tiago):
    record = arm_geometry(tiago).record()
    assert record["srdf"] is None and record["srdf_disabled"] == {} and record["pairs_checked"] > 1000


def _link_distances(geometry, q_arm):
    """Every checked pair of links' smallest signed mesh distance, from coal's distance query on all
    pairs (the verdict asks only the colliding ones)."""
    pin.computeDistances(geometry.model, geometry.data, geometry.geom, geometry.geom_data, q_arm)
    objs, out = geometry.geom.geometryObjects, {}
    for pair, result in zip(geometry.geom.collisionPairs, geometry.geom_data.distanceResults, strict=True):
        key = frozenset((objs[pair.first].name.rsplit("_", 1)[0], objs[pair.second].name.rsplit("_", 1)[0]))
        out[key] = min(out.get(key, np.inf), result.min_distance)
    return out


def test_a_self_collision_names_the_deepest_pair_first_with_its_time_and_waypoint(tiago):
    """The start, held, then the hand tucked into the torso: the message names the column with the
    hand's safety box first (the deepest, as coal's distance query finds it at every sample), with
    the time and the waypoints where it is deepest (the spline overshoots the tucked posture between
    waypoints 3 and 4); the first pair in the geometry's order is another."""
    geometry = arm_geometry(tiago)
    first = geometry.contact(TIAGO_TUCKED)
    assert {first.first, first.second} == {"torso_fixed_column_link_0", "arm_4_link_0"}
    t = np.arange(5.0)
    q = np.zeros((5, tiago.nq))
    q[:, N_BASE:] = [TIAGO_START, TIAGO_START, TIAGO_START, TIAGO_TUCKED, TIAGO_TUCKED]
    verdict = judge(tiago, t, q, given_force(t, np.zeros((5, 3)), 0.0), 0.9)
    v = verdict.violations[verdict.failed.index("self_collision")]
    s = sample_motion(tiago, t, q)
    distances = [_link_distances(geometry, qk[N_BASE:]) for qk in s.q]
    pair = frozenset(("torso_fixed_column_link", "hand_safety_box"))
    depths = np.array([-d[pair] for d in distances])
    deepest = max(-d for dk in distances for d in dk.values())
    assert depths.max() == pytest.approx(deepest) and deepest > 0.04
    i = int(np.argmax(depths))
    k = int(np.floor(s.t[i]))  # waypoints 1 s apart
    where = f"(waypoint {k})" if s.t[i] == k else f"(between waypoints {k} and {k + 1})"
    named = v.detail.split(": ", 1)[1].split("; ")
    assert named[0] == (f"torso_fixed_column_link with hand_safety_box {1e3 * deepest:.3g} mm deep at "
                        f"t = {s.t[i]:.3g} s {where}"), v.detail
    assert v.worst == pytest.approx(deepest) and v.units == "m" and v.limit == 0.0
    assert len(named) == 3 and "more pairs" in v.detail
    later = [float(re.search(r" ([\d.]+) mm deep", n).group(1)) for n in named]
    assert later == sorted(later, reverse=True)


def test_a_plans_robot_block_records_the_srdf_it_was_judged_with(tiago, tmp_path):
    from forte.io.robot_file import store_robot
    from forte.model.robot import default_robot

    panda = store_robot(default_robot(), tmp_path)["self_collision"]
    assert panda["srdf"] == "erd:panda_description/srdf/panda.srdf" and panda["srdf_disabled"]["Never"] > 0
    assert store_robot(tiago, tmp_path)["self_collision"] == arm_geometry(tiago).record()
    assert store_robot(tiago, tmp_path)["self_collision"]["srdf"] is None


@pytest.mark.parametrize("preset", ["authors", "ur5", "kinova", "tiago"])
def test_the_broad_phase_spheres_never_part_a_pair_closer_than_the_margin(preset):
    """Where :meth:`ArmGeometry.near_pairs` says a pair is apart, coal's distance of its meshes is
    above :data:`BROAD_PHASE_MARGIN` too (the spheres contain the geometries)."""
    g = arm_geometry(preset_robot(preset))
    rng = np.random.default_rng(5)
    Q = rng.uniform(np.maximum(g.model.lowerPositionLimit, -np.pi), np.minimum(g.model.upperPositionLimit, np.pi),
                    (30, g.model.nq))
    near = g.near_pairs(Q)
    assert near.shape == (30, g.pairs) and near.any() and not near.all()
    for q, row in zip(Q, near, strict=True):
        pin.updateGeometryPlacements(g.model, g.data, g.geom, g.geom_data, q)
        for i in np.flatnonzero(~row):
            assert pin.computeDistance(g.geom, g.geom_data, int(i)).min_distance > BROAD_PHASE_MARGIN


@pytest.mark.parametrize("preset", ["authors", "tiago"])
def test_contacts_through_the_broad_phase_are_contacts_one_by_one(preset):
    g = arm_geometry(preset_robot(preset))
    rng = np.random.default_rng(6)
    Q = rng.uniform(np.maximum(g.model.lowerPositionLimit, -np.pi), np.minimum(g.model.upperPositionLimit, np.pi),
                    (600, g.model.nq))
    one_by_one = [g.contact(q) for q in Q]
    assert 20 < sum(c is not None for c in one_by_one) < 580  # both kinds, and first pairs that differ
    assert len({c for c in one_by_one if c is not None}) > 3
    assert g.contacts(Q) == one_by_one


@pytest.mark.parametrize("preset", ["authors", "tiago"])
def test_the_clearances_hulls_and_bounds_on_the_shared_geometry_change_no_answer(preset):
    """The clearance builds its parts on the geometry this check loads (hulls of the meshes, local
    AABBs of the shapes): a geometry so used answers as an untouched one, contacts and depths."""
    from forte.model.clearance import _convex, _part

    robot = preset_robot(preset)
    untouched, used = (ArmGeometry(Path(robot.urdf_path), tuple(robot.arm_joints), locked_key(robot))
                       for _ in range(2))
    for obj in used.geom.geometryObjects:
        _part(obj.name, _convex(obj.geometry)[0])
    rng = np.random.default_rng(12)
    Q = rng.uniform(np.maximum(used.model.lowerPositionLimit, -np.pi),
                    np.minimum(used.model.upperPositionLimit, np.pi), (300, used.model.nq))
    assert [used.contact(q) for q in Q] == [untouched.contact(q) for q in Q]
    assert [used.link_contacts(q) for q in Q[:60]] == [untouched.link_contacts(q) for q in Q[:60]]
