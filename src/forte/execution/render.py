"""Pictures of a running simulation: offscreen frames (PNG files or an mp4 video).

:class:`FrameRecorder` renders with ``mujoco.Renderer``, which needs an offscreen OpenGL context
(``MUJOCO_GL=egl`` or ``osmesa``, chosen before MuJoCo is first imported). The simulation loop
calls :meth:`FrameRecorder.capture` every ``frame_every`` control steps and
:meth:`FrameRecorder.finish` once at the end.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import mujoco
import numpy as np

from forte.exceptions import SimulationError
from forte.execution.model import SimModel


class FrameRecorder:
    """Offscreen frames for ``--frames DIR`` (PNG) or ``--video FILE.mp4`` (ffmpeg).

    Args:
        sim: The model to render (its meshes should be kept: ``build_sim_model(meshes=True)``).
        frames_dir: Folder for ``frame_00000.png, ...`` (None: no PNG files).
        video: mp4 file written with ``ffmpeg`` at ``fps`` (None: no video).
        fps: Frame rate of the video.
        size: Image ``(width, height)`` in pixels.

    Raises:
        SimulationError: no ``ffmpeg`` for a video, or no offscreen OpenGL context.
    """

    def __init__(self, sim: SimModel, frames_dir: Path | None, video: Path | None, fps: float,
                 size: tuple[int, int]) -> None:
        self.frames_dir, self.video, self.fps = frames_dir, video, fps
        self.frames: list[np.ndarray] = []
        if video is not None and shutil.which("ffmpeg") is None:
            raise SimulationError(f"video {video}: writing mp4 needs 'ffmpeg' on PATH; use --frames DIR")
        gl = os.environ.get("MUJOCO_GL", "<unset>")
        try:
            self.renderer = mujoco.Renderer(sim.model, height=size[1], width=size[0])
            self.camera = mujoco.MjvCamera()
            self.camera.type = mujoco.mjtCamera.mjCAMERA_FREE
            self.camera.distance, self.camera.azimuth, self.camera.elevation = 3.0, 135.0, -20.0
            self.capture(sim)
            self.frames.clear()
        except Exception as exc:  # MuJoCo/PyOpenGL raise assorted types when no context exists
            raise SimulationError(
                f"offscreen rendering could not initialise (MUJOCO_GL={gl}): {exc}. Set MUJOCO_GL=egl "
                "(GPU or Mesa EGL) or MUJOCO_GL=osmesa before Python starts, or run without "
                "--video/--frames"
            ) from exc

    def capture(self, sim: SimModel) -> None:
        """Render the current state, the camera looking at the end effector."""
        self.camera.lookat[:] = sim.data.site_xpos[sim.ee_site]
        self.renderer.update_scene(sim.data, self.camera)
        self.frames.append(self.renderer.render().copy())

    def finish(self) -> list[Path]:
        """Write the PNG frames and/or the video; return the paths written."""
        self.renderer.close()
        written: list[Path] = []
        if self.frames_dir is not None:
            written += self._write_frames(self.frames_dir)
        if self.video is not None and self.frames:
            self._write_video(self.video)
            written.append(self.video)
        return written

    def _write_frames(self, folder: Path) -> list[Path]:
        from PIL import Image

        folder.mkdir(parents=True, exist_ok=True)
        written = []
        for i, frame in enumerate(self.frames):
            path = folder / f"frame_{i:05d}.png"
            Image.fromarray(frame).save(path)
            written.append(path)
        return written

    def _write_video(self, video: Path) -> None:
        h, w = self.frames[0].shape[:2]
        tmp = video.with_name(f".{video.stem}.tmp.mp4")
        cmd = ["ffmpeg", "-y", "-loglevel", "error", "-f", "rawvideo", "-pix_fmt", "rgb24",
               "-s", f"{w}x{h}", "-r", str(self.fps), "-i", "-", "-pix_fmt", "yuv420p", str(tmp)]
        proc = subprocess.run(cmd, input=b"".join(f.tobytes() for f in self.frames),
                              capture_output=True, check=False)
        if proc.returncode != 0:
            tmp.unlink(missing_ok=True)
            raise SimulationError(f"video {video}: ffmpeg failed: {proc.stderr.decode()[-300:]}")
        os.replace(tmp, video)
