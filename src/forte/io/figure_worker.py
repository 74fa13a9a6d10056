"""A process forked before the solve that imports matplotlib while this one plans, then draws
the plan's figures (Linux).

In this process an import thread would compete for the GIL with the planner; a process does not.
:func:`figure_worker` starts one for the plans of a block, :func:`draw_plan_figures` hands it the
plan, or draws here (:func:`forte.io.figures.plan_figures`) where none waits, the plan's robot is
another or the worker fails. The processes follow the rules of :mod:`forte.io.figure_processes`:
only where a core is probably idle, always waited for.
"""

from __future__ import annotations

import contextlib
import os
import pickle
import signal
from collections.abc import Iterator
from contextvars import ContextVar
from dataclasses import replace
from pathlib import Path
from typing import Any

from forte.io import figures
from forte.io.figure_processes import exited_ok, run_child, try_fork, use_processes
from forte.planning.planner import Plan


class FigureWorker:
    """A forked process holding ``robot`` that imports matplotlib, then draws one plan's figures.

    The plan goes to it through a pipe without its robot and task (the worker has the robot from
    the fork; the task does not pickle); it answers ``ok`` through another once the files exist.
    """

    def __init__(self, robot: Any) -> None:
        self.robot = robot
        self.used = False
        self.pid, self._send, self._answers = -1, -1, -1
        fds: list[int] = []
        with contextlib.suppress(OSError):
            fds += os.pipe()
            fds += os.pipe()
        pid = try_fork() if len(fds) == 4 else None
        if pid is None:  # no pipe or process to be had: no worker (pid -1), the figures are drawn here
            for fd in fds:
                os.close(fd)
            return
        requests, self._send, self._answers, answer = fds
        self.pid = pid
        if self.pid == 0:
            os.close(self._send)
            os.close(self._answers)
            run_child(lambda: self._serve(requests, answer))
        os.close(requests)
        os.close(answer)

    def _serve(self, requests: int, answer: int) -> None:
        figures.pyplot()
        import mpl_toolkits.mplot3d  # noqa: F401

        with os.fdopen(requests, "rb") as fh:
            data = fh.read()
        if not data:  # the parent needs no figures
            return
        light, directory, fmt = pickle.loads(data)
        with figures.figure_format(fmt):
            figures.plan_figures(replace(light, robot=self.robot), Path(directory))
        os.write(answer, b"ok")

    def draw(self, plan: Any, directory: Path, fmt: str) -> bool:
        """Have the worker draw ``plan``'s figures into ``directory``; False when it did not."""
        if getattr(plan.robot, "fingerprint", None) != getattr(self.robot, "fingerprint", None):
            self.close()
            return False
        self.used = True
        try:
            with os.fdopen(self._send, "wb") as fh:
                self._send = -1
                fh.write(pickle.dumps((replace(plan, robot=None, task=None), str(directory), fmt)))
            with os.fdopen(self._answers, "rb") as fh:
                self._answers = -1
                answer = fh.read()
        except OSError:  # the worker died (its pipe broke): draw here
            answer = b""
        return self._wait() and answer == b"ok"

    def close(self) -> None:
        """Stop the worker if it has not drawn (nothing of it is needed)."""
        if self.pid > 0 and not self.used:
            with contextlib.suppress(ProcessLookupError):
                os.kill(self.pid, signal.SIGKILL)
        self.used = True
        self._wait()

    def _wait(self) -> bool:
        for fd in (self._send, self._answers):
            if fd >= 0:
                os.close(fd)
        self._send = self._answers = -1
        if self.pid <= 0:
            return False
        pid, self.pid = self.pid, -1
        return exited_ok(pid)


_WORKER: ContextVar[FigureWorker | None] = ContextVar("forte_figure_worker", default=None)


@contextlib.contextmanager
def figure_worker(robot: Any, fork: bool | None = None) -> Iterator[FigureWorker | None]:
    """Inside the block, the next plan of ``robot`` has its figures drawn by a
    :class:`FigureWorker` started now where :func:`can_fork` and ``fork`` (None: when
    :func:`idle_core`) and the OS gives a process; else None, and the figures are drawn here."""
    worker = FigureWorker(robot) if use_processes(fork) else None
    if worker is not None and worker.pid <= 0:  # it could not start
        worker = None
    token = _WORKER.set(worker)
    try:
        yield worker
    finally:
        _WORKER.reset(token)
        if worker is not None:
            worker.close()


def take_worker() -> FigureWorker | None:
    """The unused worker of this block (then used), or None; :meth:`FigureWorker.draw` checks the robot."""
    worker = _WORKER.get()
    if worker is None or worker.used or worker.pid <= 0:
        return None
    return worker


def draw_plan_figures(plan: Plan, directory: Path) -> None:
    """The figures of a plan directory (:func:`forte.io.figures.plan_figures`, in the format of
    :func:`~forte.io.figures.figure_format`): by the worker of this block when one waits for this
    plan's robot, else here."""
    worker = take_worker()
    if worker is not None and worker.draw(plan, directory, figures.current_format()):
        return
    figures.plan_figures(plan, directory)
