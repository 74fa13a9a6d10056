"""Synthetic depth images of a scene: a pinhole camera in MuJoCo, for sensed scenes whose truth is known.

The camera follows :mod:`forte.model.occupancy`'s convention: its pose is the *optical* frame's
(z forward, x right, y down), pixel ``(u, v)`` (column, row) looks along ``((u - cx) / fx,
(v - cy) / fy, 1)``, and the image holds the depth ``z`` along the optical axis (m; 0 where the
ray meets nothing within ``max_range``).

- :func:`ray_depth` casts one ray per pixel with ``mujoco.mj_multiRay`` against the scene's
  bodies and the floor plane (no graphics needed); the hit's distance along the unit ray ``r``
  is ``z |d|`` for the pixel direction ``d`` above, so ``z = r / |d|``.
- :func:`render_depth` renders the same image with ``mujoco.Renderer`` (OpenGL: EGL or OSMesa
  through ``MUJOCO_GL``): MuJoCo's camera looks along its -z with y up, the optical frame turned
  by pi about x, its vertical field of view ``2 atan(H / (2 fy))``; it needs ``fx = fy`` and the
  principal point at the image's centre, ``((W - 1) / 2, (H - 1) / 2)``.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from forte.exceptions import SimulationError
from forte.execution.contact import add_scene
from forte.model.occupancy import Intrinsics
from forte.model.scene import Scene
from forte.validation import FloatArray


def scene_model(scene: Scene) -> mujoco.MjModel:
    """A MuJoCo model of the scene's bodies and its floor (a plane at the floor's height)."""
    spec = mujoco.MjSpec()
    if scene.floor is not None:
        spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 1], pos=[0, 0, float(scene.floor)])
    add_scene(spec, scene)
    return spec.compile()


def pixel_rays(intrinsics: Intrinsics, width: int, height: int) -> FloatArray:
    """Per pixel (H x W x 3), its direction ``((u - cx) / fx, (v - cy) / fy, 1)`` in the optical frame."""
    v, u = np.mgrid[0:height, 0:width].astype(float)
    return np.stack([(u - intrinsics.cx) / intrinsics.fx, (v - intrinsics.cy) / intrinsics.fy, np.ones_like(u)],
                    axis=-1)


def ray_depth(scene: Scene, pose: Any, intrinsics: Intrinsics, width: int, height: int,
              max_range: float = 10.0, robot: Any = None, q: Any = None) -> FloatArray:
    """The depth image (H x W, m) of ``scene`` from a camera whose optical frame is at ``pose``
    (4x4); with ``robot``, the robot (MuJoCo's model of it, :mod:`forte.execution.model`) stands
    in the scene at whole-body configuration ``q`` and is seen too."""
    if robot is None:
        model = scene_model(scene)
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
    else:
        from forte.execution.model import build_sim_model

        sim = build_sim_model(robot, scene=scene)
        sim.set_state(q)
        model, data = sim.model, sim.data
    d = pixel_rays(intrinsics, width, height).reshape(-1, 3)
    norm = np.linalg.norm(d, axis=1)
    pose = np.asarray(pose, dtype=float)
    directions = np.ascontiguousarray((d / norm[:, None]) @ pose[:3, :3].T).ravel()
    n = len(d)
    geom, dist = np.full(n, -1, dtype=np.int32), np.full(n, -1.0)
    origin = np.ascontiguousarray(pose[:3, 3])
    try:
        mujoco.mj_multiRay(model, data, origin, directions, None, 1, -1, geom, dist, None, n, max_range * norm.max())
    except TypeError:  # MuJoCo before 3.3: no normals argument
        mujoco.mj_multiRay(model, data, origin, directions, None, 1, -1, geom, dist, n, max_range * norm.max())
    z = np.where(geom >= 0, dist / norm, 0.0)
    return np.where(z <= max_range, z, 0.0).reshape(height, width)


def render_depth(scene: Scene, pose: Any, intrinsics: Intrinsics, width: int, height: int) -> FloatArray:
    """:func:`ray_depth`'s image rendered by OpenGL (module docstring); ``SimulationError`` when
    the camera is not one MuJoCo renders or there is no OpenGL context."""
    if (abs(intrinsics.fx - intrinsics.fy) > 1e-9 or abs(intrinsics.cx - (width - 1) / 2) > 1e-9
            or abs(intrinsics.cy - (height - 1) / 2) > 1e-9):
        raise SimulationError("render_depth: MuJoCo's camera needs fx = fy and the principal point at the centre")
    spec = mujoco.MjSpec()
    if scene.floor is not None:
        spec.worldbody.add_geom(type=mujoco.mjtGeom.mjGEOM_PLANE, size=[0, 0, 1], pos=[0, 0, float(scene.floor)])
    add_scene(spec, scene)
    pose = np.asarray(pose, dtype=float)
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, np.ascontiguousarray(pose[:3, :3] @ np.diag([1.0, -1.0, -1.0])).ravel())
    fovy = float(np.degrees(2 * np.arctan(height / (2 * intrinsics.fy))))
    spec.worldbody.add_camera(name="depth", pos=pose[:3, 3].tolist(), quat=quat.tolist(), fovy=fovy)
    spec.visual.global_.offwidth, spec.visual.global_.offheight = max(width, 640), max(height, 480)
    spec.visual.map.znear = 0.001  # of the model's extent: the default clips what is near the lens
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    try:
        with mujoco.Renderer(model, height, width) as renderer:
            renderer.enable_depth_rendering()
            renderer.update_scene(data, camera="depth")
            return np.array(renderer.render(), dtype=float)
    except Exception as exc:  # no OpenGL context: MuJoCo raises several kinds
        raise SimulationError(f"render_depth: no OpenGL context ({str(exc).splitlines()[0]})") from exc
