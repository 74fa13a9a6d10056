"""An interactive 3D replay of a plan in the Rerun viewer (``rerun-sdk``).

:func:`record_plan` logs, on the timeline ``time`` (seconds from the plan's start):

- ``world/robot/<geometry>/mesh``: the robot's meshes (the STL collision meshes of the URDF, which
  Rerun reads; COLLADA visual meshes are not), posed at every waypoint by Pinocchio's forward
  kinematics of the whole-body URDF (:func:`forte.io.whole_body.whole_body_urdf`);
- ``world/scene/<name>``: the plan's scene (:mod:`forte.model.scene`), each body posed once
  (static): boxes, cylinders, spheres (ellipsoids), capsules, and meshes as the triangles the
  planner's loader (coal) reads;
- ``world/base_path`` and ``world/ee_path``: the base (x, y on the floor) and end-effector paths;
- ``world/force``: the desired force at the end effector, drawn at :data:`FORCE_SCALE` m per N;
- ``force_space/rfp``: the residual force polytope ``{f : A f <= b}`` of the waypoint (N), with
  ``force_space/force`` (the desired force f) and ``force_space/ball`` (the uncertainty ball of
  radius r around f), in its own 3D view, in newtons;
- ``plots/capacity/{capacity,f_norm,f_plus_r,f_minus_r}``: directional capacity vs ``|f|`` and
  ``|f| +- r`` (N), and
  ``plots/manipulability`` (Yoshikawa, unitless), from metrics.csv.

``--save FILE.rrd`` writes a recording that ``rerun FILE.rrd`` opens later; without it the viewer
is spawned (it needs a display).
"""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from forte.capability.polytope import trajectory_rfp
from forte.exceptions import InvalidInputError
from forte.io.plandir import read_metrics, read_plan_dir
from forte.io.whole_body import whole_body_urdf
from forte.model.scene import Box, Capsule, Cylinder, Scene, Sphere, mesh_vertices
from forte.planning.methods.catalog import METHODS

#: Length of the force arrow in the robot scene (m per N).
FORCE_SCALE = 0.005
MESH_SUFFIXES = (".stl", ".obj", ".glb", ".gltf")
#: Colour of the scene's bodies (RGBA, 0-255).
SCENE_COLOR = [150, 120, 90, 200]


def _rerun() -> Any:
    try:
        import rerun as rr
    except ImportError as exc:
        raise InvalidInputError("forte view needs the 'rerun-sdk' package: pip install 'forte[view]'") from exc
    return rr


def _geometry(robot: Any) -> tuple[Any, Any, list[tuple[str, str, Any]]]:
    """Pinocchio model, geometry model and the (name, mesh file, scale) of each drawable mesh."""
    import pinocchio as pin

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "robot.urdf"
        path.write_text(whole_body_urdf(robot))
        model = pin.buildModelFromUrdf(str(path))
        geom = pin.buildGeomFromUrdf(model, str(path), pin.GeometryType.COLLISION)
    meshes = []
    for g in geom.geometryObjects:
        mesh = str(getattr(g, "meshPath", "") or "")
        if Path(mesh).suffix.lower() in MESH_SUFFIXES and Path(mesh).is_file():
            meshes.append((g.name, mesh, np.asarray(g.meshScale, dtype=float)))
    return model, geom, meshes


def record_plan(plan_dir: str | Path, save: str | Path | None = None, spawn: bool = False) -> Path | None:
    """Log the plan in ``plan_dir`` to Rerun: to ``save`` (an ``.rrd`` file) or a spawned viewer.

    Returns:
        The recording's path when ``save`` is given.
    """
    import pinocchio as pin

    rr = _rerun()
    if save is not None:
        save = Path(save)
        if save.suffix.lower() != ".rrd":
            raise InvalidInputError(f"--save {save}: expected a .rrd file name")
        if not save.parent.is_dir():
            raise InvalidInputError(f"--save {save}: folder {save.parent} does not exist")
    plan = read_plan_dir(plan_dir)
    metrics = read_metrics(plan_dir)
    robot = plan.robot
    rec = rr.RecordingStream("forte", recording_id=f"forte-view-{Path(plan_dir).name}")
    if save is not None:
        rec.save(str(save))
    elif spawn:
        rec.spawn()
    color = METHODS[plan.method].style.color if plan.method in METHODS else "#1f77b4"
    label = METHODS[plan.method].style.label if plan.method in METHODS else plan.method
    rec.send_blueprint(_blueprint(rr, label))
    model, geom, meshes = _geometry(robot)
    data, gdata = model.createData(), pin.GeometryData(geom)
    rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
    for name, mesh, scale in meshes:
        rec.log(f"world/robot/{name}/mesh", rr.Asset3D(path=mesh, albedo_factor=[0.75, 0.75, 0.78, 1.0]),
                static=True)
        if not np.allclose(scale, 1.0):
            rec.log(f"world/robot/{name}/mesh", rr.Transform3D(scale=scale.tolist()), static=True)
    _log_scene(rec, rr, plan.scene)
    ee = np.array([robot.ee_position(q) for q in plan.q])
    base = np.column_stack([plan.q[:, :2], np.zeros(len(plan.q))])
    rec.log("world/base_path", rr.LineStrips3D([base], colors=[[90, 90, 90]]), static=True)
    rec.log("world/ee_path", rr.LineStrips3D([ee], colors=[_rgb(color)]), static=True)
    rfps = trajectory_rfp(robot, plan.q, plan.t)
    force = plan.force
    t0 = float(plan.t[0])
    for k, q in enumerate(plan.q):
        rec.set_time("time", duration=float(plan.t[k]) - t0)
        pin.forwardKinematics(model, data, q)
        pin.updateGeometryPlacements(model, data, geom, gdata)
        for name, _, _ in meshes:
            M = gdata.oMg[geom.getGeometryId(name)]
            rec.log(f"world/robot/{name}", rr.Transform3D(translation=M.translation, mat3x3=M.rotation))
        rfp = rfps.at(k)
        if len(rfp.vertices) >= 4:
            rec.log("force_space/rfp", rr.Mesh3D(vertex_positions=rfp.vertices, triangle_indices=rfp.faces,
                                                 albedo_factor=[*np.array(_rgb(color)) / 255, 0.35]))
        else:
            rec.log("force_space/rfp", rr.Clear(recursive=False))
        if force is not None:
            f, r = force.f[k], float(force.r[k])
            rec.log("world/force", rr.Arrows3D(origins=[ee[k]], vectors=[FORCE_SCALE * f],
                                                colors=[[214, 39, 40]]))
            rec.log("force_space/force", rr.Arrows3D(origins=[[0, 0, 0]], vectors=[f], colors=[[214, 39, 40]],
                                                      labels=[f"f = {np.linalg.norm(f):.1f} N"]))
            rec.log("force_space/ball", rr.Ellipsoids3D(centers=[f], half_sizes=[[r, r, r]],
                                                         colors=[[214, 39, 40]], fill_mode="solid"))
        if metrics:
            mag = float(np.linalg.norm([metrics["fx"][k], metrics["fy"][k], metrics["fz"][k]]))
            rk = float(metrics["radius"][k])
            rec.log("plots/capacity/capacity", rr.Scalars(float(metrics["directional_capacity"][k])))
            rec.log("plots/capacity/f_norm", rr.Scalars(mag))
            rec.log("plots/capacity/f_plus_r", rr.Scalars(mag + rk))
            rec.log("plots/capacity/f_minus_r", rr.Scalars(max(mag - rk, 0.0)))
            rec.log("plots/manipulability", rr.Scalars(float(metrics["manipulability"][k])))
    _series_styles(rec, rr, color)
    rec.flush()
    if save is not None:
        rec.disconnect()
        return save
    return None


def _log_scene(rec: Any, rr: Any, scene: Scene) -> None:
    """The scene's bodies as static entities ``world/scene/<name>``, posed by their 4x4 poses."""
    for obj in scene.objects:
        path = f"world/scene/{rr.escape_entity_path_part(obj.name)}"
        rec.log(path, rr.Transform3D(translation=obj.pose[:3, 3], mat3x3=obj.pose[:3, :3]), static=True)
        s, style = obj.shape, {"colors": [SCENE_COLOR], "fill_mode": "solid", "labels": [obj.name]}
        if isinstance(s, Box):
            shape = rr.Boxes3D(half_sizes=[np.asarray(s.size) / 2], **style)
        elif isinstance(s, Sphere):
            shape = rr.Ellipsoids3D(half_sizes=[[s.radius] * 3], **style)
        elif isinstance(s, Cylinder):
            shape = rr.Cylinders3D(lengths=[s.length], radii=[s.radius], **style)
        elif isinstance(s, Capsule):  # Rerun's capsule starts at the origin; forte's is centred
            shape = rr.Capsules3D(lengths=[s.length], radii=[s.radius], translations=[[0, 0, -s.length / 2]], **style)
        else:
            g = obj.collision_geometry()
            triangles = [[g.tri_indices(i)[j] for j in range(3)] for i in range(g.num_tris)]
            shape = rr.Mesh3D(vertex_positions=mesh_vertices(s), triangle_indices=triangles,
                              albedo_factor=[c / 255 for c in SCENE_COLOR])
        rec.log(f"{path}/shape", shape, static=True)


def _series_styles(rec: Any, rr: Any, color: str) -> None:
    styles = {"capacity": (_rgb(color), "directional capacity (N)"), "f_norm": ([0, 0, 0], "|f| (N)"),
              "f_plus_r": ([214, 39, 40], "|f| + r (N)"), "f_minus_r": ([255, 152, 150], "|f| - r (N)")}
    for name, (rgb, text) in styles.items():
        rec.log(f"plots/capacity/{name}", rr.SeriesLines(colors=[rgb], names=[text]), static=True)
    rec.log("plots/manipulability", rr.SeriesLines(colors=[_rgb(color)], names=["manipulability (Yoshikawa)"]),
            static=True)


def _blueprint(rr: Any, label: str) -> Any:
    rrb = rr.blueprint
    return rrb.Blueprint(rrb.Horizontal(
        rrb.Spatial3DView(origin="world", name=f"robot ({label}); force arrow 5 mm per N"),
        rrb.Vertical(
            rrb.Spatial3DView(origin="force_space", name="residual force polytope, f and ball r (N)"),
            rrb.TimeSeriesView(origin="plots/capacity", name="capacity vs |f| +- r (N)"),
            rrb.TimeSeriesView(origin="plots/manipulability", name="manipulability"),
        ),
        column_shares=[3, 2],
    ))


def _rgb(color: str) -> list[int]:
    from matplotlib.colors import to_rgb

    return [int(round(255 * c)) for c in to_rgb(color)]
