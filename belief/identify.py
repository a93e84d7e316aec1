"""Algorithm 1 of Zhu et al. 2018: Bayesian optimization of E(θ) over a discretized latent grid,
returning a distribution P over the grid instead of a point.

::

    input: objective E, decoder z -> θ, grid of latent cells, budget (evaluations and/or seconds), seed
    1  evaluate E at an initial design of n_init cells (scrambled Sobol points of the latent box,
       snapped to their nearest cells; ``method="random"``: a seeded random permutation of cells)
    2  repeat until the budget is spent:
    3      fit the GP surrogate to the successful evaluations              (belief.surrogate)
    4      choose q unevaluated cells maximizing log EI (kriging believer)  (belief.acquisition)
    5      evaluate E at θ = decoder(z) of each chosen cell, journal each   (belief.journal)
    6      update P from the GP (only when a ``callback`` wants it: it costs a pass over the grid)
    7  fit the GP to all evaluations; return P, the history, the best θ and the marginals of P

``method="random"`` replaces steps 3-4 by the next cells of the permutation (random search
baseline; with the ``Identity`` decoder on ``SobolCandidates`` it is random search in the full
space). BO in the full space is ``method="bo"`` with the same decoder and candidates.

Failed evaluations (the objective raised :class:`physics.errors.PhysicsError` or returned NaN/inf)
are journalled with status "failed" and error NaN, never proposed again, and left out of the GP
fit (``impute_failed=True`` instead gives them the worst observed error, which pushes the search
away from them). Their cells get P = 0.

Determinism: every batch is a function of the seed and the history before it (the GP fit starts
from fixed values and runs single-threaded, ties break to the lowest cell index), so a journalled
run that is killed and resumed ends with exactly the history (cells, z, θ, E, status) of an
uninterrupted run (wall-clock ``seconds`` differ, and so can a ``time_budget`` stop). Each
evaluation is journalled as soon as it finishes, also inside a parallel batch when
``objective.evaluate_batch`` takes ``on_result`` (physics.TrajectoryError does): a kill mid-batch
loses only the evaluations still running, and the resumed run evaluates just the batch's missing
cells. The returned history is ordered by batch, then cell index, because a parallel batch
finishes in any order.

Time budget: counts the journalled seconds of replayed evaluations plus this session's wall time;
it is checked before each evaluation.

Why not botorch/Ax: the project uses pyro.contrib.gp for the GP (DESIGN.md), and the loop is over
a finite set of cells, which needs no continuous acquisition optimizer.
"""
from __future__ import annotations

import concurrent.futures as cf
import inspect
import math
import os
import time
from typing import Any, Callable, Literal, Sequence

import numpy as np
import xarray as xr
from scipy.stats import qmc
from tqdm.auto import tqdm

from belief.acquisition import select_cells
from belief.errors import BeliefError, BudgetError, GridError, JournalError, ObjectiveError
from belief.journal import Journal, Record
from belief.posterior import PosteriorConfig, estimate_noise_var, marginals, posterior_from_surrogate
from belief.result import IdentificationResult, history_dataset
from belief.surrogate import GPSurrogate, SurrogateConfig
from physics.errors import PhysicsError

__all__ = ["identify", "problem_fingerprint"]

_METHODS = ("bo", "random")


def _space_config(space: Any) -> dict[str, Any]:
    return {"names": list(space.names), "units": list(space.units),
            "lower": [float(v) for v in space.lower], "upper": [float(v) for v in space.upper]}


def problem_fingerprint(
    objective: Any, decoder: Any, grid: Any, *, space: Any, seed: int, method: str, q: int, n_init: int,
    surrogate: SurrogateConfig, impute_failed: bool,
) -> dict[str, Any]:
    """The JSON-able identity of an identification problem, stored in and checked against a journal."""
    fp: dict[str, Any] = {
        "space": _space_config(space), "decoder": decoder.config(), "grid": grid.config(), "seed": int(seed),
        "method": method, "q": int(q), "n_init": int(n_init), "impute_failed": bool(impute_failed),
        "surrogate": {k: getattr(surrogate, k) for k in surrogate.__dataclass_fields__},
    }
    fpf = getattr(objective, "fingerprint", None)
    if callable(fpf):
        fp["objective"] = fpf()
    return fp


def _validate(objective: Any, decoder: Any, grid: Any, space: Any, budget: Any, time_budget: Any,
              method: str, q: Any, n_init: Any, workers: Any, seed: Any) -> tuple[Any, int, int]:
    if not callable(objective):
        raise ObjectiveError(f"objective must be callable theta -> float, got {type(objective).__name__}.")
    space = space if space is not None else getattr(objective, "space", None)
    if space is None:
        raise BeliefError("identify needs the parameter space: pass space=... or give the objective a .space attribute.")
    dspace = getattr(decoder, "space", None)
    if dspace is None or not callable(getattr(decoder, "decode", None)):
        raise BeliefError(f"decoder must have .space and .decode(z) (an embeddings.Decoder), got {type(decoder).__name__}.")
    if tuple(dspace.names) != tuple(space.names) or not (
        np.allclose(dspace.lower, space.lower) and np.allclose(dspace.upper, space.upper)
    ):
        raise BeliefError(
            f"decoder's parameter space {list(dspace.names)} (bounds) differs from the objective's "
            f"{list(space.names)}; build the decoder on objective.space."
        )
    for attr in ("points", "size", "dim", "bounds", "to_dataarray", "config", "nearest"):
        if not hasattr(grid, attr):
            raise GridError(f"grid lacks .{attr}; pass a belief.Grid or belief.SobolCandidates.")
    if grid.size < 1:
        raise GridError("grid is empty (0 cells); give points_per_dim >= 2 or n >= 1.")
    if grid.dim != decoder.dim:
        raise GridError(
            f"grid has {grid.dim} latent dimensions but the decoder has {decoder.dim}; build the grid with "
            "Grid.for_decoder(decoder, ...)."
        )
    lo, hi = decoder.bounds[:, 0], decoder.bounds[:, 1]
    tol = 1e-9 * (hi - lo)
    if np.any(grid.bounds[:, 0] < lo - tol) or np.any(grid.bounds[:, 1] > hi + tol):
        raise GridError(f"grid bounds {grid.bounds.tolist()} leave the decoder's latent box {decoder.bounds.tolist()}.")
    if not isinstance(seed, (int, np.integer)) or isinstance(seed, bool):
        raise BeliefError(f"seed must be an integer, got {seed!r}.")
    if budget is None and time_budget is None:
        raise BudgetError("give budget=N evaluations and/or time_budget=seconds; both are None.")
    if budget is not None:
        if not isinstance(budget, (int, np.integer)) or isinstance(budget, bool):
            raise BudgetError(f"budget must be an integer number of evaluations, got {budget!r}.")
        if budget < 1:
            raise BudgetError(f"budget must be >= 1 evaluation, got {budget!r}; a zero budget identifies nothing.")
        if budget > grid.size:
            raise BudgetError(
                f"budget={budget} exceeds the {grid.size} grid cells (each cell is evaluated at most once); "
                "use a finer grid or a smaller budget."
            )
    if time_budget is not None and not (isinstance(time_budget, (int, float)) and math.isfinite(time_budget)
                                        and time_budget > 0):
        raise BudgetError(f"time_budget must be a positive number of seconds, got {time_budget!r}.")
    if method not in _METHODS:
        raise BeliefError(f"method must be one of {_METHODS}, got {method!r}.")
    if not isinstance(q, (int, np.integer)) or q < 1:
        raise BudgetError(f"q (cells per batch) must be an integer >= 1, got {q!r}.")
    if not isinstance(workers, (int, np.integer)) or workers < 1:
        raise BeliefError(f"workers must be an integer >= 1, got {workers!r}.")
    n_target = int(budget) if budget is not None else int(grid.size)
    if n_init is None:
        n_init = max(5, decoder.dim + 1)
    if not isinstance(n_init, (int, np.integer)) or n_init < 1:
        raise BudgetError(f"n_init must be an integer >= 1, got {n_init!r}.")
    if method == "bo" and n_init < 2:
        raise BudgetError(f"method='bo' needs n_init >= 2 initial evaluations to fit the GP, got {n_init}.")
    return space, n_target, int(n_init)


def _initial_cells(grid: Any, n: int, seed: int) -> list[int]:
    """n distinct cells nearest to scrambled Sobol points of the latent box (filled from a seeded permutation)."""
    n = min(n, grid.size)
    sob = qmc.Sobol(grid.dim, scramble=True, seed=seed)
    u = sob.random(int(2 ** math.ceil(math.log2(max(n, 1)))))
    pts = qmc.scale(u, grid.bounds[:, 0], grid.bounds[:, 1])
    cells: list[int] = []
    for c in grid.nearest(pts):
        if int(c) not in cells:
            cells.append(int(c))
        if len(cells) == n:
            return cells
    for c in np.random.default_rng([seed, 3]).permutation(grid.size):
        if int(c) not in cells:
            cells.append(int(c))
        if len(cells) == n:
            break
    return cells


def _as_error(value: Any) -> float:
    if isinstance(value, (tuple, list)) and len(value) == 2 and isinstance(value[1], str):
        value = value[0]
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ObjectiveError(
            f"objective must return a scalar error (float), got {type(value).__name__}: {value!r}."
        ) from None
    if arr.shape != ():
        raise ObjectiveError(f"objective must return a scalar error, got an array of shape {arr.shape}; sum it.")
    return float(arr)


def _call_one(objective: Callable[[np.ndarray], Any], theta: np.ndarray) -> tuple[float, str, str, float]:
    t0 = time.perf_counter()
    try:
        value = objective(theta)
    except PhysicsError as exc:
        return float("nan"), "failed", f"{type(exc).__name__}: {exc}", time.perf_counter() - t0
    dt = time.perf_counter() - t0
    err = _as_error(value)
    if not math.isfinite(err):
        return float("nan"), "failed", f"objective returned a non-finite error ({err!r})", dt
    return err, "ok", "", dt


def _row_result(err: Any, status: str, seconds: float, message: str) -> tuple[float, str, str, float]:
    """(error, status, message, seconds) of one batch row, failures as NaN with the reason."""
    value = _as_error(err)
    if status != "ok" or not math.isfinite(value):
        return (float("nan"), "failed", f"evaluate_batch status {status!r}, error {value!r}"
                + (f": {message}" if message else ""), float(seconds))
    return value, "ok", "", float(seconds)


def _accepts_on_result(fn: Callable[..., Any]) -> bool:
    try:
        return "on_result" in inspect.signature(fn).parameters
    except (TypeError, ValueError):
        return False


def _batch_results(objective: Any, thetas: np.ndarray,
                   commit: Callable[[int, tuple[float, str, str, float]], None]) -> None:
    """Evaluate a batch with ``objective.evaluate_batch`` and ``commit(k, (error, status, message, seconds))``
    each row. If ``evaluate_batch`` takes ``on_result`` (physics.TrajectoryError does), rows are
    committed as they finish (completion order), so a kill mid-batch loses only the running ones.
    Otherwise rows are (error, status) pairs or floats, committed when the batch returns; a result
    object with ``seconds`` and ``messages`` arrays (physics.BatchResult) gives per-row times and
    reasons, else the batch wall time is split evenly."""
    done: set[int] = set()

    def stream(k: int, err: Any, status: str, seconds: float, message: str) -> None:
        done.add(int(k))
        commit(int(k), _row_result(err, status, seconds, message))

    t0 = time.perf_counter()
    try:
        if _accepts_on_result(objective.evaluate_batch):
            raw_obj = objective.evaluate_batch(thetas, on_result=stream)
        else:
            raw_obj = objective.evaluate_batch(thetas)
    except PhysicsError as exc:
        dt = (time.perf_counter() - t0) / len(thetas)
        for k in range(len(thetas)):
            if k not in done:
                commit(k, (float("nan"), "failed", f"{type(exc).__name__}: {exc}", dt))
        return
    dt = (time.perf_counter() - t0) / len(thetas)
    raw = list(raw_obj)
    if len(raw) != len(thetas):
        raise ObjectiveError(f"objective.evaluate_batch returned {len(raw)} results for {len(thetas)} thetas.")
    seconds = getattr(raw_obj, "seconds", None)
    messages = getattr(raw_obj, "messages", None)
    for k, item in enumerate(raw):
        if k in done:
            continue
        status = item[1] if isinstance(item, (tuple, list)) and len(item) == 2 and isinstance(item[1], str) else "ok"
        sec = float(seconds[k]) if seconds is not None and len(seconds) == len(raw) else dt
        why = str(messages[k]) if messages is not None and len(messages) == len(raw) and messages[k] else ""
        commit(k, _row_result(item, status, sec, why))


def identify(
    objective: Callable[[np.ndarray], float],
    decoder: Any,
    grid: Any,
    *,
    budget: int | None = None,
    seed: int,
    journal: "str | os.PathLike[str] | None" = None,
    time_budget: float | None = None,
    method: Literal["bo", "random"] = "bo",
    q: int = 1,
    n_init: int | None = None,
    posterior: Literal["likelihood", "minimizer"] | None = "likelihood",
    noise_var: float | None = None,
    space: Any = None,
    surrogate: SurrogateConfig | None = None,
    posterior_config: PosteriorConfig | None = None,
    workers: int = 1,
    impute_failed: bool = False,
    progress: bool = True,
    callback: Callable[[int, xr.DataArray], None] | None = None,
) -> IdentificationResult:
    """Identify θ by Algorithm 1 (module docstring) and return the posterior over ``grid``.

    ``objective``: callable θ (shape ``D``) -> E (float), optionally with ``space``,
    ``evaluate_batch(thetas n x D)``, ``noise_var``, ``n_observations`` and ``fingerprint()``;
    ``decoder``: an ``embeddings.Decoder``; ``grid``: ``belief.Grid`` or ``belief.SobolCandidates``
    over ``decoder.bounds``. ``budget``: evaluations; ``time_budget``: seconds (either or both);
    ``seed``: all randomness; ``journal``: SQLite path, resumed if it exists; ``q``: cells per batch
    (evaluated with ``objective.evaluate_batch`` if present, else on ``workers`` threads);
    ``n_init``: initial design size (default max(5, d + 1)); ``posterior``: mode of P, or None to
    skip it; ``noise_var``: sigma^2 of the likelihood mode (default: ``objective.noise_var``, else
    estimated); ``callback(n_evaluations, P)``: called after every batch with the updated P
    (computing it costs one extra pass over the grid per batch).
    """
    space, n_target, n_init = _validate(objective, decoder, grid, space, budget, time_budget, method, q, n_init,
                                        workers, seed)
    seed = int(seed)
    scfg = surrogate or SurrogateConfig()
    if posterior is not None and posterior_config is not None and posterior_config.mode != posterior:
        raise BeliefError(
            f"posterior={posterior!r} contradicts posterior_config.mode={posterior_config.mode!r}; give one of them."
        )
    pcfg = posterior_config or PosteriorConfig(mode=posterior or "likelihood", noise_var=noise_var)
    if noise_var is not None and pcfg.noise_var is None:
        pcfg = PosteriorConfig(**{**pcfg.__dict__, "noise_var": noise_var})
    fp = problem_fingerprint(objective, decoder, grid, space=space, seed=seed, method=method, q=int(q),
                             n_init=n_init, surrogate=scfg, impute_failed=impute_failed)
    points = np.asarray(grid.points)
    jr = Journal(journal, fp) if journal is not None else None
    try:
        records = jr.records() if jr is not None else []
        for r in records:
            if not (0 <= r.cell < grid.size) or not np.array_equal(np.asarray(r.z), points[r.cell]):
                raise JournalError(f"journal {journal!r}: evaluation of cell {r.cell} does not match the grid.")
        if budget is not None:
            records = records[:n_target]
        perm = np.random.default_rng([seed, 1]).permutation(grid.size) if method == "random" else None
        t_start = time.perf_counter()
        replayed_seconds = float(sum(r.seconds for r in records))
        stopped = "budget"

        def elapsed() -> float:
            return replayed_seconds + time.perf_counter() - t_start

        def fit(hist: Sequence[Record]) -> GPSurrogate | None:
            ok = [r for r in hist if r.status == "ok"]
            Z = [r.z for r in ok]
            E = [r.error for r in ok]
            if impute_failed and ok:
                worst = max(E)
                bad = [r for r in hist if r.status != "ok"]
                Z += [r.z for r in bad]
                E += [worst] * len(bad)
            if len(Z) < 2:
                return None
            return GPSurrogate(grid.bounds, config=scfg).fit(np.asarray(Z), np.asarray(E))

        def propose(b: int, hist: Sequence[Record], size: int) -> tuple[list[int], GPSurrogate | None, Any]:
            evaluated = {r.cell for r in hist}
            if method == "random":
                return [int(c) for c in perm if int(c) not in evaluated][:size], None, None
            if b == 0:
                return _initial_cells(grid, size, seed), None, None
            model = fit(hist)
            if model is None:  # fewer than 2 successes: keep exploring along a seeded permutation
                order = np.random.default_rng([seed, 4, b]).permutation(grid.size)
                return [int(c) for c in order if int(c) not in evaluated][:size], None, None
            avail = np.ones(grid.size, dtype=bool)
            avail[list(evaluated)] = False
            pred = model.predict(points)
            return select_cells(model, points, avail, q=size, prediction=pred), model, pred

        def _noise(ok_errors: np.ndarray) -> float | None:
            if pcfg.mode != "likelihood":
                return None
            if pcfg.noise_var is not None:
                return pcfg.noise_var
            nv = getattr(objective, "noise_var", None)
            if nv is not None:
                return float(nv)
            return estimate_noise_var(ok_errors, n_observations=int(getattr(objective, "n_observations", 1)),
                                      dim=decoder.dim)

        def _posterior(model: GPSurrogate, hist: Sequence[Record], pred: Any = None) -> xr.DataArray:
            failed = np.zeros(grid.size, dtype=bool)
            failed[[r.cell for r in hist if r.status != "ok"]] = True
            ok_err = np.array([r.error for r in hist if r.status == "ok"])
            sseed = int(np.random.SeedSequence([seed, 2, len(hist)]).generate_state(1)[0])
            return posterior_from_surrogate(model, grid, config=pcfg, noise_var=_noise(ok_err), failed=failed,
                                            seed=sseed, prediction=pred)

        bar = tqdm(total=n_target, initial=len(records), disable=not progress, desc=f"identify[{method}]",
                   leave=False)
        b = 0
        while True:
            n_before = sum(1 for r in records if r.batch < b)
            if n_before >= n_target or n_before >= grid.size:
                stopped = "budget" if n_before >= n_target else "exhausted"
                break
            size = min(n_init if b == 0 else int(q), n_target - n_before, grid.size - n_before)
            in_batch = [r for r in records if r.batch == b]
            if len(in_batch) >= size:
                b += 1
                continue
            if time_budget is not None and elapsed() >= time_budget:
                stopped = "time"
                break
            hist = [r for r in records if r.batch < b]
            cells, model, pred = propose(b, hist, size)
            done_cells = {r.cell for r in in_batch}
            if not done_cells <= set(cells):
                raise JournalError(
                    f"journal {journal!r} diverges from the deterministic replay at batch {b}; it was written by "
                    "another version or options. Use a new journal path."
                )
            todo = [c for c in cells if c not in done_cells]
            zs = points[todo]
            thetas = decoder.decode(zs)
            if callback is not None and model is not None and posterior is not None:
                callback(n_before, _posterior(model, hist, pred))
            out_of_time = False

            def commit(k: int, res: tuple[float, str, str, float]) -> None:
                rec = Record(b, int(todo[k]), tuple(float(v) for v in zs[k]), tuple(float(v) for v in thetas[k]),
                             res[0], res[3], res[1], res[2])
                if jr is not None:
                    jr.append(rec)
                records.append(rec)
                bar.update(1)
                oks = [r.error for r in records if r.status == "ok"]
                if oks:
                    bar.set_postfix(best=f"{min(oks):.4g}", refresh=False)

            if len(todo) > 1 and callable(getattr(objective, "evaluate_batch", None)):
                _batch_results(objective, thetas, commit)
            elif len(todo) > 1 and workers > 1:
                with cf.ThreadPoolExecutor(max_workers=int(workers)) as ex:
                    futs = [ex.submit(_call_one, objective, th) for th in thetas]
                    for k, fut in enumerate(futs):
                        commit(k, fut.result())
            else:
                for k, th in enumerate(thetas):
                    if k > 0 and time_budget is not None and elapsed() >= time_budget:
                        out_of_time = True
                        break
                    commit(k, _call_one(objective, th))
            if out_of_time:
                stopped = "time"
                break
            b += 1
        bar.close()
        # canonical order: by batch, then cell (a parallel batch is journalled in completion order)
        records.sort(key=lambda r: (r.batch, r.cell))

        ok = [r for r in records if r.status == "ok"]
        if not records:
            raise BudgetError(f"time_budget={time_budget!r} s was spent before the first evaluation; raise it.")
        if not ok:
            raise ObjectiveError(
                f"all {len(records)} evaluations failed (first: {records[0].message}); the parameter box may be "
                "non-physical for this simulator, or the objective is broken."
            )
        best = min(ok, key=lambda r: r.error)
        best_theta = xr.DataArray(np.asarray(best.theta), dims=("parameter",),
                                  coords={"parameter": list(space.names), "unit": ("parameter", list(space.units))},
                                  name="best_theta")
        P = marg = None
        if posterior is not None:
            model = fit(records)
            if model is None:
                raise ObjectiveError(f"only {len(ok)} successful evaluation(s); the posterior needs at least 2.")
            P = _posterior(model, records)
            marg = marginals(P, decoder.decode(points), space, level=pcfg.level,
                             identified_ratio=pcfg.identified_ratio)
        hist_ds = history_dataset(records, latent_names=tuple(f"z{i}" for i in range(grid.dim)), space=space)
        config = dict(fp)
        config.update({"budget": budget, "time_budget": time_budget, "posterior": pcfg.mode if posterior else None,
                       "noise_var": _noise(np.array([r.error for r in ok])) if posterior else None,
                       "stopped": stopped, "n_evaluations": len(records)})
        return IdentificationResult(posterior=P, history=hist_ds, marginals=marg, best_theta=best_theta,
                                    best_error=float(best.error), config=config)
    finally:
        if jr is not None:
            jr.close()
