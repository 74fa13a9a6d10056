"""A stop (Ctrl-C, SIGTERM) held back while the sweep driver writes a record, then let through.

A stop reaches the driver as an exception (``KeyboardInterrupt``: Python's SIGINT handler, or
the one ``forte sweep`` installs for SIGTERM) raised between any two bytecodes of the main
thread. Landing between the rename of a cell file and the log line and count that record it,
or in the middle of the final table, marker and end event, it left records that disagree
(issue 28). :func:`held_stops` runs such a block with the stop signals noted instead of handled;
at its end the handlers are put back and each noted signal is raised again, so the stop then
acts exactly as it would have (an exception, or the default action), only after the record.
"""

from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator
from typing import Any

#: The signals a sweep treats as a stop.
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)


@contextlib.contextmanager
def held_stops() -> Iterator[None]:
    """Hold :data:`STOP_SIGNALS` for the block (see the module docstring); keep it short.

    A stop pending on entry is raised by the entry itself (``signal.signal`` runs pending
    handlers first): the block then never starts, which is as consistent as finishing it.
    """
    if threading.current_thread() is not threading.main_thread():
        yield  # Python runs signal handlers in the main thread only: no stop lands here
        return
    caught: list[int] = []
    saved: dict[int, Any] = {}
    try:
        for sig in STOP_SIGNALS:
            handler = signal.getsignal(sig)
            if handler is None:  # installed outside Python: it could not be put back
                continue
            saved[sig] = handler
            signal.signal(sig, lambda signum, _frame: caught.append(signum))
        yield
    finally:
        _put_back(saved)
        for sig in dict.fromkeys(caught):  # once per signal, in arrival order
            signal.raise_signal(sig)


def _put_back(saved: dict[int, Any]) -> None:
    """Restore the ``saved`` handlers, every one of them: ``signal.signal`` runs pending handlers
    first, so a stop that an already restored handler turns into an exception is raised only once
    all are back (else the other signal would stay held for good)."""
    raised: BaseException | None = None
    for sig, handler in saved.items():
        while True:
            try:
                signal.signal(sig, handler)
                break
            except BaseException as exc:  # noqa: BLE001 - a handler's stop, raised below
                raised = raised or exc
    if raised is not None:
        raise raised
