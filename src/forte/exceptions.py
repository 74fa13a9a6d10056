"""Exceptions raised by forte.

Every error a user can trigger with bad input derives from :class:`ForteError`, carries a
message that names the offending field (file, key, waypoint, joint) and what was expected,
and is reported by the CLI as one line with a non-zero exit code, never as a traceback.
"""

from __future__ import annotations


class ForteError(Exception):
    """Base class of every error raised on purpose by forte."""


class InvalidInputError(ForteError, ValueError):
    """A value handed to forte has the wrong shape, type or range."""


class RobotModelError(ForteError):
    """The robot description cannot be loaded or is inconsistent (URDF, frame, joint names)."""


class TaskFileError(ForteError):
    """A task file is missing, unreadable or fails validation."""


class InfeasibleTaskError(ForteError):
    """The task cannot be met: for example an end-effector pose the robot cannot reach."""


class SolverError(ForteError):
    """The optimizer failed; ``status`` is the solver's own return status."""

    def __init__(self, message: str, status: str = "unknown") -> None:
        super().__init__(message)
        self.status = status


class EstimationError(ForteError):
    """A mass estimate could not be obtained or failed validation."""


class SimulationError(ForteError):
    """The simulation could not be built or run."""


class OutputError(ForteError):
    """An output path forte may not write: a file or folder it did not create, or not writable."""
