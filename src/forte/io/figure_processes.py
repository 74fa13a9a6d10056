"""Work done by other processes, so that it uses the second core (Linux).

:func:`run_split` runs groups of calls, the first here and the others in forked children (a
plan's four figures: two processes); :mod:`forte.io.figure_worker` forks, before the solve, a
process that then draws the plan's figures. Both fall back to working in this process.

Processes are used only where a core is probably idle (:func:`idle_core`): on a busy machine a
second process would only share this one's core. A child never returns into its caller: it ends
with ``os._exit`` (:func:`run_child`). A child that fails has its work done again here, so an
error is raised here, with its traceback; children are always waited for. Where no process can
be had (``fork`` or ``pipe`` fails: EAGAIN, ENOMEM, EMFILE), the work is done here.
"""

from __future__ import annotations

import os
import sys
import threading
import warnings
from collections.abc import Callable

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


def use_processes(fork: bool | None) -> bool:
    """``fork`` (None: decide by :func:`idle_core`), where :func:`can_fork`."""
    return can_fork() and (idle_core() if fork is None else fork)


def try_fork() -> int | None:
    """``os.fork()``, or None where the OS has no process to give (the caller works alone)."""
    sys.stdout.flush()
    sys.stderr.flush()
    try:
        return os.fork()
    except OSError:
        return None


def exited_ok(pid: int) -> bool:
    try:
        return os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1]) == 0
    except ChildProcessError:  # reaped elsewhere: its result is unknown
        return False


def run_child(work: Callable[[], None]) -> None:
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
    if not use_processes(fork):
        for call in (call for group in groups for call in group):
            call()
        return
    children: list[tuple[int | None, list[Callable[[], None]]]] = []
    try:
        for group in groups[1:]:
            pid = try_fork()
            if pid == 0:
                run_child(lambda group=group: [call() for call in group])
            children.append((pid, group))
        for call in groups[0]:
            call()
    finally:  # a group without a process (fork failed) or whose child failed runs here
        failed = [group for pid, group in children if pid is None or not exited_ok(pid)]
    for group in failed:
        for call in group:
            call()
