"""Stops held while a sweep writes a record (issue 28)."""

from __future__ import annotations

import signal

import pytest

from forte.experiments.sweep.stops import held_stops


def _stop() -> None:
    signal.raise_signal(signal.SIGTERM)


def test_a_held_stop_is_raised_after_the_block_and_the_handlers_are_put_back():
    class Stop(Exception):
        pass

    def stop(signum, frame):
        raise Stop(signum)

    sigint = signal.getsignal(signal.SIGINT)
    previous = signal.signal(signal.SIGTERM, stop)
    try:
        done = []
        with pytest.raises(Stop), held_stops():
            _stop()
            _stop()
            done.append("whole block")
        with pytest.raises(KeyboardInterrupt), held_stops():  # Ctrl-C: Python's own handler
            signal.raise_signal(signal.SIGINT)
            done.append("again")
        assert done == ["whole block", "again"]
        assert signal.getsignal(signal.SIGTERM) is stop and signal.getsignal(signal.SIGINT) is sigint
    finally:
        signal.signal(signal.SIGTERM, previous)
