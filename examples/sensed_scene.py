"""The depth image of examples/tasks/sensed-crate.yaml, rendered from a known scene.

Run: ``python examples/sensed_scene.py``. A camera on a mast beside the robot's start (the
optical frame 1.8 m up and 0.5 m to the left, looking 0.25 rad right of +x and 0.6 rad down;
320 x 240 pixels, fx = fy = 200) sees a crate on the straight base path, a table to its right,
the floor, and the robot's own arm at its start configuration. MuJoCo casts one ray per pixel
(:func:`forte.execution.depth_camera.ray_depth`); the image is saved as a 16-bit PNG in
millimetres, as depth cameras write it. The task file reads it back into boxes, removes the
floor and the robot's own points, and plans around what is left; :data:`TRUE_SCENE` is the truth
the plan is checked against (tests/test_sensed_scene.py).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from forte.model.occupancy import Intrinsics
from forte.model.scene import Box, Scene, SceneObject, pose_matrix

HERE = Path(__file__).parent
IMAGE = HERE / "tasks" / "sensed-crate-depth.png"
#: What the camera sees (the task file does not know it).
TRUE_SCENE = Scene((SceneObject("crate", Box((0.5, 0.6, 0.45)), pose_matrix([1.5, 0.0, 0.225, 0, 0, 0])),
                    SceneObject("table", Box((0.6, 0.8, 0.72)), pose_matrix([1.6, -0.95, 0.36, 0, 0, 0]))), 0.0)
#: The camera's optical frame (z forward, x right, y down) in the world: the task's depth_image pose.
CAMERA_POSE = [0.0, 0.5, 1.8, -np.pi / 2 - 0.6, 0.0, -np.pi / 2 - 0.25]
WIDTH, HEIGHT = 320, 240
INTRINSICS = Intrinsics(200.0, 200.0, (WIDTH - 1) / 2, (HEIGHT - 1) / 2)
MAX_RANGE = 4.0


def render() -> np.ndarray:
    """The depth image (m) with the built-in robot at its start configuration in view."""
    from forte.execution.depth_camera import ray_depth
    from forte.model.robot import default_robot

    robot = default_robot()
    return ray_depth(TRUE_SCENE, pose_matrix(CAMERA_POSE), INTRINSICS, WIDTH, HEIGHT, MAX_RANGE, robot=robot,
                     q=robot.home())


def save(depth: np.ndarray, path: Path = IMAGE) -> None:
    """``depth`` (m) as a 16-bit PNG of millimetres (0: no return)."""
    from PIL import Image

    Image.fromarray(np.round(depth * 1000).astype(np.uint16)).save(path)


if __name__ == "__main__":
    image = render()
    save(image)
    print(f"wrote {IMAGE} ({WIDTH} x {HEIGHT}, {np.count_nonzero(image)} pixels with a return)")
