"""Progress where a person waits: one reporter, a tiny interface the stages call.

The stages call the module functions; they do nothing unless a reporter is active (the library
API is silent by default). The ``forte`` command activates one on standard error when it is a
terminal and ``--quiet`` is not given (:func:`for_cli`)::

    from forte import progress

    with progress.step("compiling forte kernels", expected_s=10):  # spinner, elapsed / expected
        ...
    progress.update("iteration 12: objective 347.4, constraint violation 3e-07")  # detail line
    progress.note("wrote runs/lift")                                                # a permanent line

Finished steps leave one permanent line (``done: compiling forte kernels (9.8 s)``); the detail
lines are transient and redrawn at most :data:`REFRESH_S` apart, so a fast loop pays almost
nothing for them.
"""

from __future__ import annotations

import contextlib
import sys
import time
from collections.abc import Iterator
from contextvars import ContextVar
from typing import IO, Any

#: Least time between two redraws of the transient detail line (s).
REFRESH_S = 0.1


class Reporter:
    """Draws steps, their detail line and notes with ``rich`` on ``file`` (standard error)."""

    def __init__(self, file: IO[str] | None = None, force_terminal: bool | None = None,
                 width: int | None = None) -> None:
        from rich.console import Console

        self.console = Console(file=file or sys.stderr, force_terminal=force_terminal, highlight=False,
                               soft_wrap=True, width=width)
        self._live: Any = None
        self._title = ""
        self._detail = ""
        self._start = 0.0
        self._expected: float | None = None
        self._drawn = 0.0
        self.ipopt_iterations = True

    # -- drawing ----------------------------------------------------------------------------
    def _renderable(self) -> Any:
        from rich.spinner import Spinner
        from rich.text import Text

        elapsed = time.perf_counter() - self._start
        clock = f"{elapsed:.0f} s" + (f" of about {self._expected:.0f} s" if self._expected else "")
        text = Text(f"{self._title} ({clock})")
        if self._detail:
            text.append(f"\n  {self._detail}", style="dim")
        return Spinner("dots", text=text)

    def _redraw(self, force: bool = False) -> None:
        now = time.perf_counter()
        if self._live is not None and (force or now - self._drawn >= REFRESH_S):
            self._live.update(self._renderable(), refresh=True)
            self._drawn = now

    # -- the interface ----------------------------------------------------------------------
    @contextlib.contextmanager
    def step(self, title: str, expected_s: float | None = None) -> Iterator[None]:
        from rich.live import Live

        if self._live is not None:  # nested: show as a detail of the outer step
            self.update(title)
            yield
            return
        self._title, self._detail, self._expected = title, "", expected_s
        self._start = time.perf_counter()
        self._live = Live(self._renderable(), console=self.console, auto_refresh=True, refresh_per_second=4,
                          transient=True, get_renderable=self._renderable)
        ok = False
        try:
            with self._live:
                yield
            ok = True
        finally:
            self._live = None
            elapsed = time.perf_counter() - self._start
            self.console.print(f"{'done' if ok else 'stopped'}: {title} ({elapsed:.1f} s)")

    def update(self, detail: str) -> None:
        self._detail = detail
        self._redraw()

    def note(self, text: str) -> None:
        self.console.print(text)


_ACTIVE: ContextVar[Reporter | None] = ContextVar("forte_progress", default=None)


def active() -> Reporter | None:
    """The reporter in effect (``None``: progress is off)."""
    return _ACTIVE.get()


@contextlib.contextmanager
def activate(reporter: Reporter | None) -> Iterator[Reporter | None]:
    """Make ``reporter`` the one the stages report to inside the ``with`` block (None: off)."""
    token = _ACTIVE.set(reporter)
    try:
        yield reporter
    finally:
        _ACTIVE.reset(token)


def for_cli(quiet: bool = False, file: IO[str] | None = None) -> Reporter | None:
    """A reporter on standard error when it is a terminal and not ``quiet``; else None (off)."""
    stream = file or sys.stderr
    if quiet or not getattr(stream, "isatty", lambda: False)():
        return None
    try:
        return Reporter(stream)
    except ImportError:  # rich missing: no progress, never an error
        return None


@contextlib.contextmanager
def step(title: str, expected_s: float | None = None) -> Iterator[None]:
    """A step that may take a while: a spinner with the elapsed (and expected) time."""
    reporter = _ACTIVE.get()
    if reporter is None:
        yield
        return
    with reporter.step(title, expected_s):
        yield


def update(detail: str) -> None:
    """Replace the detail line of the current step (cheap: redrawn at most every :data:`REFRESH_S`)."""
    reporter = _ACTIVE.get()
    if reporter is not None:
        reporter.update(detail)


def note(text: str) -> None:
    """A permanent line (only when progress is on)."""
    reporter = _ACTIVE.get()
    if reporter is not None:
        reporter.note(text)
