"""The depth image of examples/tasks/sensed-crate.yaml, rendered from a known scene.

Run: ``python examples/sensed_scene.py`` (``--figure FILE.png``: plan the task and draw it).

A camera on a mast beside the robot's start (the optical frame 1.8 m up and 0.5 m to the left,
looking 0.25 rad right of +x and 0.6 rad down; 320 x 240 pixels, fx = fy = 200) sees a crate
on the straight base path, a table to its right, the floor, and the robot's own arm at its
start configuration. MuJoCo casts one ray per pixel
(:func:`forte.execution.depth_camera.ray_depth`); the image is saved as a 16-bit PNG in
millimetres, as depth cameras write it. The task file reads it back into boxes, removes the
floor and the robot's own points, and plans around what is left; :data:`TRUE_SCENE` is the
truth the plan is checked against (tests/test_sensed_scene.py).
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


def figure(path: Path) -> None:
    """The depth image next to a top view of the plan of sensed-crate.yaml: the sensed boxes
    (grey), the true crate and table (red outlines), the base and end-effector paths."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    import forte
    from forte.model.point_files import read_depth

    task = forte.load_task(IMAGE.parent / "sensed-crate.yaml")
    plan = forte.plan(task)
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2), layout="constrained")
    shown = left.imshow(read_depth(IMAGE) / 1000, cmap="viridis")
    fig.colorbar(shown, ax=left, label="depth (m; 0: no return)", shrink=0.8)
    left.set_title(f"the camera's depth image ({WIDTH} x {HEIGHT}; the arm in view)", fontsize=9)
    left.axis("off")
    for obj in task.scene.objects:
        half = np.array(obj.shape.size[:2]) / 2
        right.add_patch(plt.Rectangle(obj.pose[:2, 3] - half, *(2 * half), color="0.7", lw=0))
    for obj in TRUE_SCENE.objects:
        half = np.array(obj.shape.size[:2]) / 2
        right.add_patch(plt.Rectangle(obj.pose[:2, 3] - half, *(2 * half), fill=False, ec="tab:red", ls="--"))
    ee = np.array([plan.robot.ee_position(q) for q in plan.q])
    right.plot(plan.q[:, 0], plan.q[:, 1], color="k", label="base path")
    right.plot(ee[:, 0], ee[:, 1], color="tab:blue", label="end effector")
    right.plot([], [], color="0.7", lw=6, label=f"sensed: {len(task.scene.objects)} boxes of 2 cm voxels")
    right.plot([], [], color="tab:red", ls="--", label="the true crate and table")
    right.set_aspect("equal")
    right.set_xlabel("x (m)")
    right.set_ylabel("y (m)")
    right.grid(alpha=0.3)
    right.legend(fontsize=8, loc="upper right")
    right.set_ylim(-1.5, 1.6)
    right.set_title("seen from above: the plan drives around what the camera saw", fontsize=9)
    fig.savefig(path, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    import sys

    if "--figure" in sys.argv:
        out = Path(sys.argv[sys.argv.index("--figure") + 1])
        figure(out)
        print(f"wrote {out}")
    else:
        image = render()
        save(image)
        print(f"wrote {IMAGE} ({WIDTH} x {HEIGHT}, {np.count_nonzero(image)} pixels with a return)")
