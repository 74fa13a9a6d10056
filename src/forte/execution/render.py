"""Pictures of a running simulation: offscreen frames (PNG files, an mp4 video) or a live window.

Both are *frame sinks*: the simulation loop calls ``capture(sim)`` every ``every`` control steps
and ``finish()`` once at the end.

* :class:`FrameRecorder` renders with ``mujoco.Renderer``, which needs an offscreen OpenGL
  context (``MUJOCO_GL=egl`` or ``osmesa``, chosen before MuJoCo is first imported).
* :class:`LiveViewer` shows MuJoCo's interactive viewer (``mujoco.viewer.launch_passive``),
  which needs a display and an OpenGL window (GLFW). :func:`check_display` tests both first: on
  failure ``launch_passive`` would wait for ever on its window thread.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import time
import warnings
from pathlib import Path
from typing import Protocol

import mujoco
import numpy as np

from forte.exceptions import SimulationError
from forte.execution.model import SimModel


class FrameSink(Protocol):
    """Something that looks at the simulation every :attr:`every` control steps."""

    every: int

    def capture(self, sim: SimModel) -> None: ...

    def finish(self) -> list[Path]: ...


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

    def __init__(self, sim: SimModel, frames_dir: Path | None, video: Path | None, fps: float = 30.0,
                 size: tuple[int, int] = (640, 480)) -> None:
        self.frames_dir, self.video, self.fps = frames_dir, video, fps
        self.every = max(1, int(round(1.0 / (fps * sim.timestep))))
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


#: Refresh rate of the interactive viewer (Hz).
VIEWER_FPS = 60.0


def check_display() -> None:
    """Raise ``SimulationError`` (one line) unless an OpenGL window can be opened.

    Checks ``DISPLAY``/``WAYLAND_DISPLAY`` on Linux, then opens and closes a hidden GLFW window.
    """
    if sys.platform.startswith("linux") and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")):
        raise SimulationError("--viewer: no display (DISPLAY and WAYLAND_DISPLAY are unset); run it on a "
                              "desktop session, or render offscreen with --video FILE.mp4 / --frames DIR")
    try:
        import glfw
    except ImportError as exc:
        raise SimulationError(f"--viewer: the 'glfw' package is missing ({exc}); pip install glfw") from exc
    display = os.environ.get("WAYLAND_DISPLAY") or os.environ.get("DISPLAY") or "the desktop"
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        window = None
        if glfw.init():
            glfw.window_hint(glfw.VISIBLE, glfw.FALSE)
            window = glfw.create_window(64, 64, "forte", None, None)
        if window:
            glfw.destroy_window(window)
        glfw.terminate()  # the viewer initialises GLFW again on its own thread
    if not window:
        why = str(caught[-1].message) if caught else "GLFW could not create an OpenGL window"
        why = re.sub(r"b'(.*)'", r"\1", why)  # GLFW errors come as "(code) b'text'"
        raise SimulationError(f"--viewer: cannot open an OpenGL window on {display}: {why}; render "
                              "offscreen with --video FILE.mp4 / --frames DIR instead")


class LiveViewer:
    """MuJoCo's interactive viewer on the running simulation, paced to real time.

    :meth:`capture` waits until the wall clock has caught up with the simulated time, then
    shows the state; :meth:`finish` keeps the window open until the user closes it.

    Raises:
        SimulationError: no display or no OpenGL window (see :func:`check_display`).
    """

    def __init__(self, sim: SimModel) -> None:
        check_display()
        import mujoco.viewer

        self.every = max(1, int(round(1.0 / (VIEWER_FPS * sim.timestep))))
        self.handle = mujoco.viewer.launch_passive(sim.model, sim.data)
        self.sim_start = float(sim.data.time)
        self.wall_start = time.perf_counter()

    def capture(self, sim: SimModel) -> None:
        """Show the current state once the wall clock has reached the simulated time."""
        if not self.handle.is_running():  # the user closed the window: simulate on without it
            return
        ahead = (float(sim.data.time) - self.sim_start) - (time.perf_counter() - self.wall_start)
        if ahead > 0:
            time.sleep(ahead)
        self.handle.sync()

    def finish(self) -> list[Path]:
        """Wait until the user closes the window (the final state stays on screen)."""
        while self.handle.is_running():
            time.sleep(0.05)
        self.handle.close()
        return []
