"""Exceptions raised by jointid.

Every exception subclasses :class:`JointIdError` and a builtin
(``ValueError``, ``OSError``, ...) so callers can catch either. The message
says what was wrong and how to fix it; the CLI prints it as one line.
"""

from __future__ import annotations

__all__ = [
    "JointIdError",
    "ModelError",
    "FrequencyError",
    "DofError",
    "StudyError",
    "DataError",
    "IdentificationError",
    "Terminated",
]


class JointIdError(Exception):
    """Base class of every error jointid raises on purpose."""


class ModelError(JointIdError, ValueError):
    """An FE model was built or used with invalid parameters."""


class FrequencyError(JointIdError, ValueError):
    """A frequency axis is invalid, or a quantity is undefined at a frequency."""


class DofError(JointIdError, KeyError):
    """A DOF label is malformed or not part of a model or FRF set."""

    def __str__(self) -> str:  # KeyError quotes its message; we do not want that
        return str(self.args[0]) if self.args else ""


class StudyError(JointIdError, ValueError):
    """A study file is invalid; the message names the key."""


class DataError(JointIdError, ValueError):
    """Measured or simulated data (FRF file, time histories) are invalid."""


class IdentificationError(JointIdError, ValueError):
    """An identification cannot be carried out as asked (e.g. too few coordinates)."""


class Terminated(BaseException):
    """The process was asked to stop (SIGTERM, e.g. a batch scheduler's time limit).

    Raised by the ``jointid`` command's signal handler so that the run unwinds like
    Ctrl-C (:class:`KeyboardInterrupt`): an open
    :class:`~jointid.io.output_dir.OutputSet` removes its staging area and lock.
    A ``BaseException``, so ``except Exception`` does not swallow it.
    """

    def __init__(self, signum: int = 15):
        super().__init__(signum)
        self.signum = signum
