"""What every scenario shares, kinematic (``wbc walk``, ``wbc balance``) or physics (``wbc sim``): the run record
and the acceptance criteria.

* :class:`RunRecord`: a dataclass of the time series of one run; :meth:`RunRecord.save` writes every array,
  name and number field to an npz log (one writer for every run type).
* :class:`Criterion`: one acceptance criterion as data — a summary entry, a comparison and a threshold —
  and :func:`evaluate`, the one place that decides ``passed``. A criterion can compare an entry to a number,
  to another entry (``minus``: the absolute difference of two entries, optionally wrapped by ``period`` for
  angles), scale its threshold by an entry (``scale_by``, e.g. 5 % of the planned distance) with a ``floor``,
  reduce a list or dict entry (``reduce``: ``max``, ``min``, ``len``, ``all``), compare element-wise against the
  magnitudes of another list entry (``threshold_key``), and accept alternatives (``either``).

A criterion whose entry is missing from the summary fails (a run that could not measure it did not show it).
"""

from __future__ import annotations

import math
import operator
from dataclasses import dataclass, field, fields
from typing import Any

import numpy as np

from wbc.exceptions import InvalidInputError

__all__ = ["Criterion", "evaluate", "RunRecord", "MotionRun"]

_OPS = {"<=": operator.le, "<": operator.lt, ">=": operator.ge, ">": operator.gt, "==": operator.eq,
        "!=": operator.ne}
_REDUCE = {"max": max, "min": min, "len": len, "all": all}


@dataclass(frozen=True)
class Criterion:
    """An acceptance criterion: ``value(summary) op threshold``.

    Args:
        description: what the criterion demands, as reported in ``failed_criteria``.
        key: summary entry; a dotted path reaches into a dict entry (``max_task_error_rad.arms``).
        op: one of ``<=``, ``<``, ``>=``, ``>``, ``==``, ``!=``.
        threshold: the bound (a number or a bool), in the entry's units.
        minus: another entry (or a number): the value is ``|summary[key] − summary[minus]|`` (wrapped into
            [−period/2, period/2] first when ``period`` is given, e.g. 2π for headings; element-wise for a list).
        scale_by: another entry: the bound is ``max(threshold · |summary[scale_by]|, floor)``.
        floor: see ``scale_by`` (units of the entry).
        reduce: ``max``/``min``/``len``/``all`` of a list entry (of the values of a dict entry) before comparing.
        threshold_key: another list entry: compare element-wise against its magnitudes (every element must hold).
        either: alternatives: the criterion also holds when one of them holds.
        detail: a format string over the summary entries, printed beside the measurement when the criterion
            fails (e.g. ``"{max_joint_speed_joint} at {max_joint_speed_ratio:.5g}×"``); left out when an entry
            it names is missing.

    ``str(criterion)`` is the requirement in words and symbols (``description (key op threshold)``);
    :meth:`report` is the failed-criterion line: the requirement, then what the run measured.

    Raises:
        InvalidInputError: unknown ``op`` or ``reduce``.
    """

    description: str
    key: str
    op: str
    threshold: Any = 0.0
    minus: str | float | None = None
    period: float | None = None
    scale_by: str | None = None
    floor: float = 0.0
    reduce: str | None = None
    threshold_key: str | None = None
    either: tuple[Criterion, ...] = field(default=())
    detail: str = ""

    def __post_init__(self):
        if self.op not in _OPS:
            raise InvalidInputError(f"criterion {self.description!r}: op {self.op!r} is not one of {sorted(_OPS)}")
        if self.reduce is not None and self.reduce not in _REDUCE:
            raise InvalidInputError(f"criterion {self.description!r}: reduce {self.reduce!r} is not one of "
                                    f"{sorted(_REDUCE)}")

    def holds(self, summary: dict) -> bool:
        """Whether the summary meets the criterion (False when an entry it needs is missing or malformed)."""
        try:
            ok = self._holds(summary)
        except (KeyError, TypeError, ValueError):
            ok = False
        return ok or any(alt.holds(summary) for alt in self.either)

    def __str__(self) -> str:
        return f"{self.description} ({self._requirement()})"

    def _requirement(self) -> str:
        """``key op bound`` in symbols, e.g. ``walked_distance_m <= 0.05 × planned_distance_m``."""
        left = self.key if self.minus is None else f"|{self.key} − {self.minus}|"
        if self.reduce is not None:
            left = f"{self.reduce}({left})"
        bound = f"|{self.threshold_key}|" if self.threshold_key is not None else _text(self.threshold)
        if self.scale_by is not None:
            bound = f"{bound} × |{self.scale_by}|"
        return f"{left} {self.op} {bound}"

    def measured(self, summary: dict):
        """The value the criterion compares (after ``minus`` and ``reduce``), or None when the summary lacks an
        entry it needs; ``(value, bound)`` are what :meth:`report` prints."""
        try:
            return self._value(summary), self._bound(summary)
        except (KeyError, TypeError, ValueError):
            return None

    def report(self, summary: dict) -> str:
        """The line of a failed criterion: ``description: measured <value>[, details] (required <op> <bound>)``;
        ``description: not measured (...)`` when the summary lacks an entry it needs. Numbers to 4 significant
        digits."""
        got = self.measured(summary)
        if got is None:
            return f"{self.description}: not measured (no summary entry {self.key!r})"
        value, bound = got
        shown = _text(value)
        if self.detail:
            try:
                shown += ", " + self.detail.format_map(summary)
            except (KeyError, TypeError, ValueError, IndexError):
                pass
        return f"{self.description}: measured {shown} (required {self.op} {_text(bound)})"

    def _value(self, summary: dict):
        value = _get(summary, self.key)
        if isinstance(value, dict):
            value = list(value.values())
        if self.minus is not None:
            other = _get(summary, self.minus) if isinstance(self.minus, str) else self.minus
            if isinstance(value, list):
                value = [abs(v - other) for v in value]
            else:
                value = value - other
                value = abs(math.remainder(value, self.period) if self.period is not None else value)
        if self.reduce is not None:
            value = _REDUCE[self.reduce](value)
        return value

    def _bound(self, summary: dict):
        if self.threshold_key is not None:
            return [abs(float(b)) for b in _get(summary, self.threshold_key)]
        if self.scale_by is not None:
            return max(self.threshold * abs(_get(summary, self.scale_by)), self.floor)
        return self.threshold

    def _holds(self, summary: dict) -> bool:
        value, bound = self._value(summary), self._bound(summary)
        compare = _OPS[self.op]
        if self.threshold_key is not None:
            bounds, values = np.asarray(bound, dtype=float), np.asarray(value, dtype=float)
            return values.shape == bounds.shape and bool(np.all(compare(values, bounds)))
        return bool(compare(value, bound))


def _get(summary: dict, key: str):
    value = summary
    for part in key.split("."):
        value = value[part]
    return value


def _text(value) -> str:
    """A measurement or bound as printed beside a verdict: floats (and lists of them) to 4 significant digits."""
    if isinstance(value, (bool, np.bool_)):
        return str(bool(value))
    if isinstance(value, (float, np.floating)):
        return f"{float(value):.4g}"
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_text(v) for v in value) + "]"
    return str(value)


def evaluate(summary: dict, criteria) -> tuple[bool, list[str]]:
    """(every criterion holds, the failed ones in order, each as :meth:`Criterion.report`: the requirement and
    the measurement beside it)."""
    failed = [c.report(summary) for c in criteria if not c.holds(summary)]
    return not failed, failed


@dataclass
class RunRecord:
    """Base of the run records (:class:`~wbc.scenarios.walk.WalkRun`, :class:`~wbc.scenarios.balance.BalanceRun`,
    :class:`~wbc.sim.closed_loop.SimRun`): dataclasses of the time series of one run, one row per control tick.

    :meth:`save` writes every field that is an array, a list of names, a string, a number or a bool (in field
    order), then the array entries of a field named ``extra`` (a dict), and skips the fields listed in the
    class attribute ``not_logged`` and ``None`` values.
    """

    not_logged = ()

    def save(self, path) -> None:
        """Write the npz log (compressed) to ``path`` (a file name or a binary file object)."""
        arrays = {}
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name == "extra" or f.name in self.not_logged or value is None:
                continue
            if isinstance(value, (np.ndarray, list, tuple, str, int, float, bool, np.generic)):
                arrays[f.name] = np.asarray(value) if isinstance(value, np.ndarray) else np.array(value)
        extra = getattr(self, "extra", None) or {}
        arrays.update({k: v for k, v in extra.items() if isinstance(v, np.ndarray) and k not in arrays})
        np.savez_compressed(path, **arrays)


@dataclass
class MotionRun(RunRecord):
    """The series every kinematic run records, N ticks, row k at t[k] = k dt: ``robot`` name; ``dt`` s; ``t``
    (N,) s; ``q`` (N, nq); ``v`` (N, nv) the command computed at row k; ``com``, ``com_ref`` (N, 3) m, world."""

    robot: str
    dt: float
    t: np.ndarray
    q: np.ndarray
    v: np.ndarray
    com: np.ndarray
    com_ref: np.ndarray
