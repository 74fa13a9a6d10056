"""Where the plan groups of a sweep run: a local process pool (default) or a Ray cluster.

Both yield the results of :func:`forte.experiments.sweep.cell.run_group` as groups finish (in any
order), and raise :class:`~forte.exceptions.ForteError` (:func:`worker_died`) when a worker
process dies (killed for memory, a crash in native code, a lost Ray node): the cells finished
until then are kept and the same command resumes. Workers are fresh processes (``spawn``, or
Ray's workers) with one BLAS/OpenMP thread each (:data:`THREAD_ENV`), so N workers use N cores
and every group computes the same numbers on either backend. Ray is imported only here and only
when asked for (an optional extra: ``pip install 'forte[ray]'``).
"""

from __future__ import annotations

import contextlib
import importlib.util
import multiprocessing
import os
import signal
import socket
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Any

from forte.exceptions import ForteError, InvalidInputError
from forte.experiments.sweep.cell import CellResult, run_group
from forte.experiments.sweep.spec import PlanGroup
from forte.system import SINGLE_THREAD_ENV, cpu_count

#: Environment of every worker: one thread per BLAS / OpenMP library (no oversubscription).
THREAD_ENV = SINGLE_THREAD_ENV
#: ``--ray`` without an address: start a local Ray instance with ``--workers`` CPUs.
LOCAL = "local"


def default_workers() -> int:
    """The CPUs this process may use (:func:`forte.system.cpu_count`)."""
    return cpu_count()


@contextlib.contextmanager
def _thread_env() -> Iterator[None]:
    """Set :data:`THREAD_ENV` for the processes started inside the block (spawned workers inherit it)."""
    saved = {k: os.environ.get(k) for k in THREAD_ENV}
    os.environ.update(THREAD_ENV)
    try:
        yield
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def worker_died(reason: str) -> ForteError:
    """The one-line error of a sweep whose worker process died (``forte sweep`` exits 2)."""
    return ForteError(f"a sweep worker died ({reason}); the finished cells are kept, run the same command "
                      "to resume")


def _death(pool: ProcessPoolExecutor, procs: Sequence[Any]) -> str:
    """How a dead one of ``procs`` (the workers of a broken ``pool``) ended: its exit status or
    signal. The pool sends SIGTERM to the others once one died, so another ending is named first."""
    manager = getattr(pool, "_executor_manager_thread", None)
    if manager is not None:  # it joins the workers: waiting beside it races for their exit status
        manager.join(timeout=5.0)
    dead = [p for p in procs if p.exitcode not in (None, 0)]
    if not dead:
        return "a pool worker process ended abruptly"
    proc = min(dead, key=lambda p: p.exitcode == -signal.SIGTERM)
    if proc.exitcode > 0:
        return f"pool worker {proc.pid} exited with status {proc.exitcode}"
    try:
        name = signal.Signals(-proc.exitcode).name
    except ValueError:
        name = f"signal {-proc.exitcode}"
    return f"pool worker {proc.pid} killed by {name}" + (", out of memory?" if name == "SIGKILL" else "")


def _worker_init(parent: int) -> None:
    """In each pool worker: leave Ctrl-C to the driver, and exit when the driver is gone (killed)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(0.5)
        os._exit(1)

    threading.Thread(target=watch, daemon=True).start()


def pool_results(groups: Sequence[PlanGroup], workers: int) -> Iterator[list[CellResult]]:
    """Run ``groups`` on ``workers`` local processes; yield each group's results when it finishes.

    Leaving the iterator early (an error, Ctrl-C) cancels the queued groups and stops the running
    ones.
    """
    if not groups:
        return
    with _thread_env():
        pool = ProcessPoolExecutor(max_workers=max(1, min(workers, len(groups))),
                                   mp_context=multiprocessing.get_context("spawn"),
                                   initializer=_worker_init, initargs=(os.getpid(),))
        done = False
        try:
            pending: set[Future[list[CellResult]]] = {pool.submit(run_group, g) for g in groups}
            while pending:
                procs = list((getattr(pool, "_processes", None) or {}).values())  # to name a dead one
                finished, pending = wait(pending, return_when=FIRST_COMPLETED)
                for future in finished:
                    try:
                        result = future.result()
                    except BrokenProcessPool:
                        raise worker_died(_death(pool, procs)) from None
                    yield result
            done = True
        finally:
            procs = list((getattr(pool, "_processes", None) or {}).values())
            pool.shutdown(wait=done, cancel_futures=True)
            if not done:  # stop the running groups too (shutdown alone waits for them at exit)
                for proc in procs:
                    _terminate(proc)


def _terminate(proc: Any) -> None:
    with contextlib.suppress(Exception):
        proc.terminate()
        proc.join(timeout=5)


def check_ray() -> None:
    """Raise :class:`InvalidInputError` (one line) when Ray is not installed."""
    if importlib.util.find_spec("ray") is None:
        raise InvalidInputError("--ray: Ray is not installed in this Python environment; expected it installed "
                                "(pip install 'forte[ray]', or pip install 'ray>=2.9')")


def _check_reachable(address: str) -> None:
    """Fail fast (one line) when ``HOST:PORT`` / ``ray://HOST:PORT`` does not answer (Ray retries for minutes)."""
    host, _, port = address.split("://", 1)[-1].rpartition(":")
    if not host or not port.isdigit():
        return  # "auto" and the like: Ray finds the address itself
    try:
        socket.create_connection((host.strip("[]"), int(port)), timeout=5).close()
    except OSError as exc:
        raise InvalidInputError(f"--ray {address}: cannot reach {host}:{port} ({exc.strerror or exc}); expected "
                                "the address of a running Ray cluster") from None


@contextlib.contextmanager
def ray_session(address: str | None, workers: int) -> Iterator[bool]:
    """Connect to Ray for the block: ``address`` ``None`` or ``"local"`` starts a local instance with
    ``workers`` CPUs, anything else is the address of a cluster (``auto``, ``HOST:PORT`` or
    ``ray://HOST:PORT``; its nodes need forte installed). A session the caller started
    (``ray.init``) is used as it is and left running. Yields whether the block owns the session
    (then ``ray.shutdown()`` at its end stops every task it left).
    """
    check_ray()
    import ray

    if ray.is_initialized():
        yield False
        return
    options: dict[str, Any] = {"include_dashboard": False, "log_to_driver": False, "logging_level": "ERROR"}
    if address not in (None, LOCAL):
        _check_reachable(address)
    # ray.init replaces the SIGTERM handler with sys.exit(15): keep the caller's (forte sweep's
    # turns SIGTERM into an interruption that writes the partial table and exits 130)
    main = threading.current_thread() is threading.main_thread()
    saved = {s: signal.getsignal(s) for s in (signal.SIGTERM, signal.SIGINT)} if main else {}
    try:
        if address in (None, LOCAL):
            ray.init(address="local", num_cpus=workers, **options)  # a new instance, even beside a cluster
        else:
            ray.init(address=address, **options)
    except (ConnectionError, ValueError, RuntimeError) as exc:
        raise InvalidInputError(f"--ray {address}: cannot connect to a Ray cluster there "
                                f"({' '.join(str(exc).split())[:200]})") from None
    finally:
        for sig, handler in saved.items():
            if handler is not None:  # None: a handler not installed from Python, cannot be put back
                signal.signal(sig, handler)
    try:
        yield True
    finally:
        ray.shutdown()


#: How often Ray re-runs a group whose worker process died before it gives up (Ray's default).
RAY_TASK_RETRIES = 3


def ray_results(groups: Sequence[PlanGroup], cancel: bool = True) -> Iterator[list[CellResult]]:
    """Run ``groups`` as Ray tasks of one CPU each (inside :func:`ray_session`); yield each group's
    results when it finishes. Leaving the iterator early cancels the others if ``cancel``: in a
    session the caller keeps running. In a session of its own :func:`backend` leaves that to
    ``ray.shutdown()``: force-cancelling tasks just before it races Ray's bookkeeping (a reply for a
    task Ray had already cancelled as queued aborts the driver, "Tried to complete task that was
    not pending", seen on SIGTERM in this project's tests with Ray 2.60).

    Ray retries a task whose worker died (:data:`RAY_TASK_RETRIES` times); a failure left after that (a
    worker crash, a lost node, out of memory) raises :func:`worker_died`. An exception raised in
    :func:`run_group` itself (``RayTaskError``: a bug) propagates as it is.
    """
    import ray
    from ray.exceptions import RayError, RayTaskError

    remote = ray.remote(num_cpus=1, max_retries=RAY_TASK_RETRIES, runtime_env={"env_vars": THREAD_ENV})(run_group)
    pending = [remote.remote(g) for g in groups]
    try:
        while pending:
            ready, pending = ray.wait(pending, num_returns=1)
            try:
                result = ray.get(ready[0])
            except RayTaskError:
                raise
            except RayError as exc:
                raise worker_died(f"{type(exc).__name__}: {' '.join(str(exc).split())[:200]}") from None
            yield result
    finally:
        for ref in pending if cancel else ():
            with contextlib.suppress(Exception):
                ray.cancel(ref, force=True)


Execute = Callable[[Sequence[PlanGroup]], Iterator[list[CellResult]]]


@contextlib.contextmanager
def backend(ray: str | None, workers: int) -> Iterator[Execute]:
    """The function that runs groups: on a local pool (``ray`` None) or on Ray (inside a session)."""
    if ray is None:
        yield lambda groups: pool_results(groups, workers)
        return
    with ray_session(ray, workers) as owned:
        yield lambda groups: ray_results(groups, cancel=not owned)
