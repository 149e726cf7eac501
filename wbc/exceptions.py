"""Every error wbc raises on purpose.

All derive from :class:`WbcError`, so ``except wbc.exceptions.WbcError`` catches anything the library reports
about bad input or an unsolvable problem. Messages name what was wrong and what would have been valid.
Subclasses also derive from the matching built-in (``ValueError``, ``KeyError``, ``FileNotFoundError``) so
generic handlers keep working.
"""

from __future__ import annotations


class WbcError(Exception):
    """Base class of every error raised by wbc."""


class UnknownRobotError(WbcError, KeyError):
    """A robot name is not in the catalog. The message lists the catalog."""

    def __str__(self) -> str:  # KeyError quotes its message; keep it readable
        return str(self.args[0]) if self.args else ""


class RobotFileNotFoundError(WbcError, FileNotFoundError):
    """A URDF, SRDF or robot descriptor file does not exist."""


class RobotDescriptionError(WbcError, ValueError):
    """A robot description is inconsistent (missing reference posture, bad sole size, ...)."""


class UnknownFrameError(WbcError, KeyError):
    """A frame name does not exist in the model. The message lists close matches."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else ""


class UnknownJointError(WbcError, KeyError):
    """A joint name does not exist in the model."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else ""


class InvalidInputError(WbcError, ValueError):
    """A numeric input has the wrong shape, is not finite, or is out of its valid range."""


class InvalidTargetError(InvalidInputError):
    """A task target has the wrong shape or contains NaN/inf."""


class ReadOnlyAttributeError(InvalidInputError, AttributeError):
    """An assignment to a read-only attribute (an ``AttributeError`` too, as Python raises for a property without a
    setter)."""


class ConfigurationError(InvalidInputError):
    """A configuration vector q (or velocity v) has the wrong size or is not finite."""


class GaitError(InvalidInputError):
    """A gait request cannot be planned (bad step count, timing, geometry...)."""


class TerrainError(InvalidInputError):
    """A terrain description cannot be parsed or built (unknown kind, bad number, malformed file)."""


class UnknownSolverError(WbcError, ValueError):
    """A QP backend name is not installed or not known. The message lists the available ones."""


class SolverError(WbcError, RuntimeError):
    """A QP solve failed. Controllers catch it, fall back to a safe command and report the tick."""


class InfeasibleProblemError(SolverError):
    """The hard constraints of a QP cannot all hold.

    Attributes:
        conflicts: list of ``(constraint_name, violation)`` pairs, violation in the constraint's own units
            (m/s, rad/s, ...) from a slack-relaxed solve, largest first.
    """

    def __init__(self, message: str, conflicts: list[tuple[str, float]] | None = None):
        super().__init__(message)
        self.conflicts = list(conflicts or [])


class SimulationError(WbcError, RuntimeError):
    """A physics simulation could not be built or stepped (bad model, diverged state...)."""
