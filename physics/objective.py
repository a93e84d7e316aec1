"""The objective contract: what belief calls to learn E(θ), and what a batch of evaluations returns.

An objective maps a parameter vector θ of shape ``(D,)`` (the order of ``space.names``) to an
error E(θ) >= 0 that is a sum over S named *segments* (contiguous pieces of the data)::

    E(θ) = Σ_{s=1..S} E_s(θ)          parts = (E_1, ..., E_S), shape (S,)

and exposes the residual vectors behind each part, so that model criticism can look at where the
model misses. The contract (:class:`Objective`, a structural ``typing.Protocol``):

- ``space``: the :class:`~physics.parameters.ParameterSpace` of θ (D parameters);
- ``segments``: ``tuple[str, ...]`` of S names, e.g. ``"t0/w1"`` (trajectory 0, window 1);
- ``__call__(θ (D,)) -> float``: E(θ); raises :class:`~physics.errors.PhysicsError` when the
  simulation diverges;
- ``evaluate_parts(θ (D,)) -> (S,)``: the parts, ``parts.sum() == E(θ)``;
- ``residuals(θ (D,)) -> list of S arrays (T_s, m)``: residual vectors x_obs - x_pred of each
  segment in time order (NaN rows where nothing was compared); for a sum-of-squares error,
  Σ_s nansum(r_s²) = E(θ);
- ``evaluate_batch(θs (n, D), *, on_result=None) -> BatchResult``: failures are recorded with a
  status, never raised; ``on_result(k, error, status, seconds, message, parts (S,))`` is called
  for each row k as soon as it is done (completion order), the result keeps the input order;
- ``n_observations``: K, the number of scalar residuals; ``noise_var``: σ² per residual when
  known, else None; ``fingerprint()``: a JSON-able dict naming data and settings (with segments).

An objective that has no residual vectors raises :class:`~physics.errors.NoResidualsError` from
``residuals`` and ``residuals_batch``; callers then fall back (belief's noise rule) or skip
(least-squares steps).

Statuses (:data:`STATUSES`), one vocabulary for batches, journals and histories: ``"ok"``;
``"diverged"`` = the simulation raised :class:`~physics.errors.PhysicsError`; ``"failed"`` = the
objective returned NaN or inf, or raised another tensegrid error. A
:class:`~physics.errors.ContractError` (an implementation returned what the contract forbids) is
a bug and propagates.

A plain function θ -> E is not an objective; :func:`as_objective` wraps it once in
:class:`FunctionObjective` (one segment ``"all"``, no residuals), so that consumers see only the
contract.

This module imports numpy only (no simulator), so ``belief`` can type against it cheaply.
"""
from __future__ import annotations

import concurrent.futures as cf
import math
import operator
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol, runtime_checkable

import numpy as np

from physics.errors import ContractError, NoResidualsError, ParameterError, PhysicsError, TensegridError

if TYPE_CHECKING:
    from physics.parameters import ParameterSpace

__all__ = ["STATUSES", "BatchResult", "Objective", "OnResult", "Row", "evaluate_row", "residual_row", "check_windows",
           "ObjectiveFunction", "FunctionObjective", "as_objective"]

STATUSES: tuple[str, ...] = ("ok", "diverged", "failed")

#: on_result(k, error, status, seconds, message, parts (S,)): one finished row of a batch.
OnResult = Callable[[int, float, str, float, str, np.ndarray], None]

#: One evaluated row: (error, status, seconds, message, parts (S,)).
Row = tuple[float, str, float, str, np.ndarray]


@dataclass(frozen=True)
class BatchResult:
    """Results of evaluating n parameter vectors, in input order.

    errors: (n,) E(θ_k) [units of E], NaN unless ok; status: n strings from :data:`STATUSES`;
    seconds: (n,) wall time of each evaluation [s]; messages: n strings, "" when ok, else why;
    parts: (n, S) per-segment errors, NaN rows unless ok, ``errors[k] == parts[k].sum()`` for ok
    rows. Validated on construction (:class:`~physics.errors.ParameterError` otherwise).
    Iterating yields ``(error, status)`` pairs.
    """

    errors: np.ndarray
    status: tuple[str, ...]
    seconds: np.ndarray
    messages: tuple[str, ...]
    parts: np.ndarray

    def __post_init__(self) -> None:
        errors = np.asarray(self.errors, dtype=float)
        seconds = np.asarray(self.seconds, dtype=float)
        parts = np.asarray(self.parts, dtype=float)
        status, messages = tuple(self.status), tuple(self.messages)
        n = len(status)
        if errors.shape != (n,) or seconds.shape != (n,) or len(messages) != n:
            raise ParameterError(
                f"BatchResult: errors, seconds and messages must have one entry per status (n = {n}); got "
                f"errors {errors.shape}, seconds {seconds.shape}, {len(messages)} messages. "
                "Build all from the same rows."
            )
        if parts.ndim != 2 or parts.shape[0] != n:
            raise ParameterError(
                f"BatchResult: parts must have shape (n, S) = ({n}, S), got {parts.shape}; give one row of "
                "per-segment errors per evaluation (a single column (n, 1) when there are no segments)."
            )
        unknown = sorted({s for s in status if s not in STATUSES})
        if unknown:
            raise ParameterError(f"BatchResult: status must be one of {STATUSES}, got {unknown}; map other "
                                 "outcomes to 'failed' and put the reason in messages.")
        self._check_rows(errors, parts, status)
        for name, value in (("errors", errors), ("seconds", seconds), ("parts", parts),
                            ("status", status), ("messages", messages)):
            object.__setattr__(self, name, value)

    @staticmethod
    def _check_rows(errors: np.ndarray, parts: np.ndarray, status: tuple[str, ...]) -> None:
        ok = np.array([s == "ok" for s in status], dtype=bool)
        if not np.isfinite(errors[ok]).all():
            raise ParameterError("BatchResult: an 'ok' row has a NaN or inf error; mark it 'failed' instead.")
        if np.isfinite(errors[~ok]).any() or np.isfinite(parts[~ok]).any():
            raise ParameterError("BatchResult: rows that are not 'ok' must have NaN errors and NaN parts; got "
                                 "finite values. Set them to NaN and keep the reason in messages.")
        total = parts[ok].sum(axis=1)
        if not np.allclose(total, errors[ok], rtol=1e-9, atol=1e-300):
            raise ParameterError(f"BatchResult: errors must equal parts.sum(1) on 'ok' rows; got errors "
                                 f"{errors[ok].tolist()} vs sums {total.tolist()}. Compute E as the sum of its parts.")

    @classmethod
    def from_rows(cls, rows: Sequence[Row], n_segments: int) -> BatchResult:
        """Assemble a result from n rows ``(error, status, seconds, message, parts (S,))``."""
        parts = np.full((len(rows), int(n_segments)), np.nan)
        for k, row in enumerate(rows):
            parts[k] = row[4]
        return cls(np.array([r[0] for r in rows], dtype=float), tuple(r[1] for r in rows),
                   np.array([r[2] for r in rows], dtype=float), tuple(r[3] for r in rows), parts)

    @property
    def n_segments(self) -> int:
        """S, the number of parts per row."""
        return int(self.parts.shape[1])

    def __len__(self) -> int:
        return len(self.status)

    def __iter__(self) -> Iterator[tuple[float, str]]:
        """Rows as (error, status) pairs."""
        return iter(zip(self.errors.tolist(), self.status, strict=True))


def check_windows(windows: Any, what: str) -> int:
    """``windows`` as an int >= 1 (segments per data set; ``what`` names what they split), else ParameterError."""
    try:
        value = 0 if isinstance(windows, bool) else operator.index(windows)
    except TypeError:
        value = 0
    if value < 1:
        raise ParameterError(f"windows must be an integer >= 1 (contiguous {what}), got {windows!r}; "
                             "pass windows=1 for a single segment.")
    return value


def evaluate_row(objective: Objective, theta: np.ndarray) -> Row:
    """One row of a batch: ``objective.evaluate_parts(theta)`` timed, its outcome mapped to a status.

    Returns (E, "ok", seconds, "", parts (S,)) with E = parts.sum(); (NaN, "diverged", ...) on
    :class:`PhysicsError`; (NaN, "failed", ...) on another :class:`TensegridError` or a NaN/inf
    part. Parts are NaN unless ok. Bugs propagate: a :class:`ContractError` and exceptions that
    are not tensegrid errors.
    """
    n_segments = len(objective.segments)
    start = time.perf_counter()
    try:
        parts = np.asarray(objective.evaluate_parts(theta), dtype=float)
    except PhysicsError as exc:
        return math.nan, "diverged", time.perf_counter() - start, str(exc), np.full(n_segments, np.nan)
    except ContractError:
        raise
    except TensegridError as exc:
        return (math.nan, "failed", time.perf_counter() - start, f"{type(exc).__name__}: {exc}",
                np.full(n_segments, np.nan))
    seconds = time.perf_counter() - start
    if parts.shape != (n_segments,) or not np.isfinite(parts).all():
        return (math.nan, "failed", seconds, f"evaluate_parts returned {parts.tolist()!r} for {n_segments} "
                "segments: not one finite value per segment", np.full(n_segments, np.nan))
    return float(parts.sum()), "ok", seconds, "", parts


def residual_row(objective: Objective, theta: np.ndarray) -> list[np.ndarray] | None:
    """``objective.residuals(theta)`` (S arrays (T_s, m)), or None when the simulation diverged
    (:class:`PhysicsError`), another tensegrid error was raised, or a residual is inf.
    :class:`NoResidualsError` (the objective has none at any θ) and bugs propagate."""
    try:
        out = [np.asarray(r, dtype=float) for r in objective.residuals(theta)]
    except (NoResidualsError, ContractError):
        raise
    except TensegridError:
        return None
    return None if any(np.isinf(r).any() for r in out) else out


@runtime_checkable
class Objective(Protocol):
    """Structural type of an objective E(θ) = Σ_s E_s(θ) (see the module docstring for the contract).

    θ has shape (D,) with D = ``space.dim``; a batch has shape (n, D); parts have shape (S,) with
    S = ``len(segments)``; ``residuals`` returns S arrays (T_s, m).
    """

    space: ParameterSpace

    @property
    def segments(self) -> tuple[str, ...]:
        """Names of the S segments whose errors sum to E."""
        ...

    @property
    def n_observations(self) -> int:
        """K, the number of scalar residuals in E."""
        ...

    @property
    def noise_var(self) -> float | None:
        """Known observation noise variance σ² per residual (units of E), or None."""
        ...

    @property
    def noise_floor(self) -> float | None:
        """The variance per residual (units of E / K) that measurement noise alone leaves at the true θ,
        measured from the data (or known), or None when the objective cannot tell; belief.scale reads
        an adequate model from it."""
        ...

    def __call__(self, theta: np.ndarray) -> float:
        """E(θ) for θ (D,); raises PhysicsError if the simulation diverges."""
        ...

    def evaluate_parts(self, theta: np.ndarray) -> np.ndarray:
        """Per-segment errors (S,) at θ (D,), summing to E(θ)."""
        ...

    def evaluate_batch(self, thetas: np.ndarray, *, on_result: OnResult | None = None) -> BatchResult:
        """E and parts at each row of θs (n, D); failures recorded with a status, not raised."""
        ...

    def residuals(self, theta: np.ndarray) -> list[np.ndarray]:
        """Residual vectors x_obs - x_pred per segment: S arrays (T_s, m), time order, NaN rows not
        compared; raises NoResidualsError when the objective has none."""
        ...

    def residuals_batch(self, thetas: np.ndarray) -> list[list[np.ndarray] | None]:
        """``residuals`` at each row of θs (n, D), None where the evaluation was not ok; raises
        NoResidualsError when the objective has none."""
        ...

    def fingerprint(self) -> dict[str, Any]:
        """JSON-able identity of data and settings, including ``segments``."""
        ...


#: A plain objective function: θ (D,) -> E(θ) (float); :func:`as_objective` wraps it.
ObjectiveFunction = Callable[[np.ndarray], float]

#: The members of :class:`Objective` that a plain function does not have.
_CONTRACT_MEMBERS = ("segments", "n_observations", "noise_var", "noise_floor", "evaluate_parts", "evaluate_batch",
                     "residuals", "residuals_batch", "fingerprint")


def _function_name(fn: Callable[..., object]) -> str:
    """``module.qualname`` of a function or of a callable object's class (a label, for fingerprints)."""
    named = fn if hasattr(fn, "__qualname__") else type(fn)
    return f"{getattr(named, '__module__', '?')}.{getattr(named, '__qualname__', type(fn).__name__)}"


class FunctionObjective:
    """A plain function θ (D,) -> E(θ) as an :class:`Objective` with one segment ``"all"``.

    parts = (E(θ),), so E = parts.sum(); ``n_observations`` (K, default 1) and ``noise_var`` (σ²,
    default unknown) are what the caller declares, since a function reports neither.
    ``residuals``/``residuals_batch`` raise :class:`NoResidualsError`: the function gives E only.
    ``evaluate_batch`` runs :func:`evaluate_row` per row, on ``workers`` threads when > 1 (useful
    when the function releases the GIL or waits on I/O), streaming rows in completion order.
    A return value that is not a scalar raises :class:`ContractError`.
    """

    def __init__(self, fn: ObjectiveFunction, space: ParameterSpace, *, workers: int = 1, n_observations: int = 1,
                 noise_var: float | None = None) -> None:
        if not callable(fn):
            raise ContractError(f"FunctionObjective wraps a function θ -> E(θ), got {type(fn).__name__}.")
        for name, value in (("workers", workers), ("n_observations", n_observations)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 1:
                raise ParameterError(f"FunctionObjective {name} must be an integer >= 1, got {value!r}.")
        if noise_var is not None and not (math.isfinite(noise_var) and noise_var > 0):
            raise ParameterError(f"FunctionObjective noise_var must be a positive σ² (units of E) or None, got "
                                 f"{noise_var!r}.")
        self.fn, self.space, self.workers = fn, space, int(workers)
        self._n_observations, self._noise_var = int(n_observations), noise_var
        self.name = _function_name(fn)

    @property
    def segments(self) -> tuple[str, ...]:
        return ("all",)

    @property
    def n_observations(self) -> int:
        return self._n_observations

    @property
    def noise_var(self) -> float | None:
        return self._noise_var

    @property
    def noise_floor(self) -> float | None:
        """A plain function's residuals are unknown: its declared σ², else None."""
        return self._noise_var

    def __call__(self, theta: np.ndarray) -> float:
        """E(θ) for θ (D,), as returned by the function (NaN and inf pass through)."""
        value = self.fn(np.asarray(theta, dtype=float))
        try:
            arr = np.asarray(value, dtype=float)
        except (TypeError, ValueError):
            raise ContractError(f"the objective function {self.name} must return a scalar error E(θ) (float), got "
                                f"{type(value).__name__}: {value!r}.") from None
        if arr.shape != ():
            raise ContractError(f"the objective function {self.name} must return a scalar error, got an array of shape "
                                f"{arr.shape}; return its sum, or implement physics.objective.Objective to report "
                                "segment errors.")
        return float(arr)

    def evaluate_parts(self, theta: np.ndarray) -> np.ndarray:
        """(E(θ),), shape (1,)."""
        return np.array([self(theta)])

    def _rows(self, thetas: np.ndarray) -> np.ndarray:
        arr = np.atleast_2d(np.asarray(thetas, dtype=float))
        if arr.ndim != 2 or arr.shape[1] != self.space.dim:
            raise ParameterError(f"thetas must have shape (n, {self.space.dim}) in the order of space.names, got "
                                 f"{np.shape(thetas)}.")
        return arr

    def evaluate_batch(self, thetas: np.ndarray, *, on_result: OnResult | None = None) -> BatchResult:
        """E at each row of θs (n, D) via :func:`evaluate_row`; on_result(k, ...) per row as it finishes."""
        arr = self._rows(thetas)
        rows: dict[int, Row] = {}

        def done(k: int, row: Row) -> None:
            rows[k] = row
            if on_result is not None:
                on_result(k, *row)

        if self.workers == 1 or len(arr) < 2:
            for k, theta in enumerate(arr):
                done(k, evaluate_row(self, theta))
        else:
            with cf.ThreadPoolExecutor(max_workers=min(self.workers, len(arr))) as pool:
                futures = {pool.submit(evaluate_row, self, theta): k for k, theta in enumerate(arr)}
                for future in cf.as_completed(futures):
                    done(futures[future], future.result())
        return BatchResult.from_rows([rows[k] for k in range(len(arr))], 1)

    def residuals(self, theta: np.ndarray) -> list[np.ndarray]:
        """Raises :class:`NoResidualsError`: a plain function gives E(θ) only."""
        raise NoResidualsError(f"the objective function {self.name} gives E(θ) only, no residual vectors; implement "
                               "physics.objective.Objective (residuals per segment) for the 'ess' noise rule, "
                               "least-squares steps and model criticism.")

    def residuals_batch(self, thetas: np.ndarray) -> list[list[np.ndarray] | None]:
        """Raises :class:`NoResidualsError` (see :meth:`residuals`)."""
        return [self.residuals(theta) for theta in self._rows(thetas)]

    def fingerprint(self) -> dict[str, Any]:
        """K, σ² and the segment. Not the function: what it computes cannot be hashed, and a journal
        must accept the same problem resumed through another function (a wrapper, a fixed crash)."""
        return {"kind": "function", "n_observations": self._n_observations, "noise_var": self._noise_var,
                "segments": list(self.segments)}

    def __repr__(self) -> str:
        return f"FunctionObjective({self.name}, D={self.space.dim}, workers={self.workers})"


def as_objective(objective: Objective | ObjectiveFunction, space: ParameterSpace | None = None, *,
                 workers: int = 1) -> Objective:
    """``objective`` itself when it implements :class:`Objective`, else a plain function wrapped in
    :class:`FunctionObjective` on ``space`` (default: the function's ``.space`` attribute) with
    ``workers`` threads per batch.

    Raises :class:`ContractError` for something neither callable nor an Objective, or an object
    with part of the contract (it would silently lose its segments); :class:`ParameterError` when
    a plain function comes without a space, or ``space`` differs from the objective's own.
    """
    if isinstance(objective, Objective):
        if space is not None and not space.same_box(objective.space):
            raise ParameterError(f"space {list(space.names)} (or its bounds) differs from the objective's own "
                                 f"{list(objective.space.names)}; leave space unset for an Objective.")
        return objective
    if not callable(objective):
        raise ContractError(f"objective must be a physics.objective.Objective or a function θ -> E(θ) (float), got "
                            f"{type(objective).__name__}.")
    present = [name for name in _CONTRACT_MEMBERS if hasattr(objective, name)]
    if present:
        missing = [name for name in _CONTRACT_MEMBERS + ("space",) if not hasattr(objective, name)]
        raise ContractError(f"{type(objective).__name__} has {present} of the Objective contract but lacks {missing}; "
                            "implement all of physics.objective.Objective, or pass a plain function θ -> E.")
    found = space if space is not None else getattr(objective, "space", None)
    if found is None:
        raise ParameterError("a plain objective function needs its parameter space: pass space=... (a "
                             "physics.ParameterSpace) or give the function a .space attribute.")
    return FunctionObjective(objective, found, workers=workers)
