"""Figures drawn by other processes, so that they use the second core (Linux).

Two tools, both falling back to drawing in this process:

- :func:`run_split` runs groups of drawing calls, the first here and the others in forked
  children (a plan's four figures: two processes);
- :func:`figure_worker` forks a process before the solve that imports matplotlib (about 0.3 s)
  while this one plans, then draws the plan's figures (:func:`forte.io.figures.plan_figures`
  hands it the plan). In this process an import thread would compete for the GIL with the
  planner; a process does not.

Both use processes only where a core is probably idle (:func:`idle_core`): on a busy machine a
second process would only share this one's core. A child never returns into its caller: it ends
with ``os._exit``. A child that fails has its work done again here, so an error is raised here,
with its traceback; children are always waited for. Where no process can be had (``fork`` or
``pipe`` fails: EAGAIN, ENOMEM, EMFILE), the work is done here.
"""

from __future__ import annotations

import contextlib
import os
import pickle
import signal
import sys
import threading
import warnings
from collections.abc import Callable, Iterator
from contextvars import ContextVar
from dataclasses import replace
from pathlib import Path
from typing import Any

from forte.system import cpu_count


def can_fork() -> bool:
    """Linux, more than one core for this process, and no other thread (a fork copies only this
    one; another may hold a lock the child would need)."""
    if not sys.platform.startswith("linux") or threading.active_count() > 1:
        return False
    try:
        return cpu_count() > 1 and len(os.listdir("/proc/self/task")) == 1
    except OSError:
        return False


def idle_core() -> bool:
    """Whether a core is probably free: the 1-minute load average at least half a core below the
    cores of this process. Measured on 2 cores: with one idle, a plan with figures takes 1.1 s
    instead of 1.5 s; with the other core busy, the second process only shares this one (1.7 s
    instead of 1.5 s)."""
    try:
        return os.getloadavg()[0] <= cpu_count() - 0.5
    except (AttributeError, OSError):
        return False


def _use_processes(fork: bool | None) -> bool:
    """``fork`` (None: decide by :func:`idle_core`), where :func:`can_fork`."""
    return can_fork() and (idle_core() if fork is None else fork)


def _fork() -> int | None:
    """``os.fork()``, or None where the OS has no process to give (the caller works alone)."""
    sys.stdout.flush()
    sys.stderr.flush()
    try:
        return os.fork()
    except OSError:
        return None


def _succeeded(pid: int) -> bool:
    try:
        return os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1]) == 0
    except ChildProcessError:  # reaped elsewhere: its result is unknown
        return False


def _child(work: Callable[[], None]) -> None:
    """In a forked child: do ``work`` and exit (status 0 when it succeeded), never return."""
    code = 1
    try:
        warnings.simplefilter("ignore")  # the parent reports, if the work fails
        work()
        code = 0
    finally:
        os._exit(code)


def run_split(groups: list[list[Callable[[], None]]], fork: bool | None = None) -> None:
    """Run every call of ``groups``: the first group here, the others in forked children where
    :func:`can_fork` and ``fork`` (None: when :func:`idle_core`), else all here, in order."""
    if not _use_processes(fork):
        for call in (call for group in groups for call in group):
            call()
        return
    children: list[tuple[int | None, list[Callable[[], None]]]] = []
    try:
        for group in groups[1:]:
            pid = _fork()
            if pid == 0:
                _child(lambda group=group: [call() for call in group])
            children.append((pid, group))
        for call in groups[0]:
            call()
    finally:  # a group without a process (fork failed) or whose child failed runs here
        failed = [group for pid, group in children if pid is None or not _succeeded(pid)]
    for group in failed:
        for call in group:
            call()


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
        pid = _fork() if len(fds) == 4 else None
        if pid is None:  # no pipe or process to be had: no worker (pid -1), the figures are drawn here
            for fd in fds:
                os.close(fd)
            return
        requests, self._send, self._answers, answer = fds
        self.pid = pid
        if self.pid == 0:
            os.close(self._send)
            os.close(self._answers)
            _child(lambda: self._serve(requests, answer))
        os.close(requests)
        os.close(answer)

    def _serve(self, requests: int, answer: int) -> None:
        from forte.io.figures import figure_format, plan_figures, pyplot

        pyplot()
        import mpl_toolkits.mplot3d  # noqa: F401

        with os.fdopen(requests, "rb") as fh:
            data = fh.read()
        if not data:  # the parent needs no figures
            return
        light, directory, fmt = pickle.loads(data)
        with figure_format(fmt):
            plan_figures(replace(light, robot=self.robot), Path(directory))
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
        return _succeeded(pid)


_WORKER: ContextVar[FigureWorker | None] = ContextVar("forte_figure_worker", default=None)


@contextlib.contextmanager
def figure_worker(robot: Any, fork: bool | None = None) -> Iterator[FigureWorker | None]:
    """Inside the block, the next plan of ``robot`` has its figures drawn by a
    :class:`FigureWorker` started now where :func:`can_fork` and ``fork`` (None: when
    :func:`idle_core`) and the OS gives a process; else None, and the figures are drawn here."""
    worker = FigureWorker(robot) if _use_processes(fork) else None
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
