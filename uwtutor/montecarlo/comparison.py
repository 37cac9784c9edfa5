"""Comparing methods on common scenarios and error conditions: ``compare`` runs them, ``ComparisonTable`` holds,
saves and reads back the table, ``BestInCell`` names a cell's best method with its evidence."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable

import numpy as np
from numpy.typing import NDArray

from .._validate import as_int, as_positive
from ..filters.base import FilterResult
from ._scores import DEFAULT_DIVERGENCE_THRESHOLD
from .study import run_study

__all__ = ["ComparisonTable", "BestInCell", "compare", "scenario_draw"]


def _scenario_condition_draw(scenario: Callable[..., Any], condition: Callable[..., Any],
                             rng: np.random.Generator, n: int) -> tuple[Any, Any]:
    """The draw of a (scenario, condition) pair: the scenario's runs, corrupted by the condition."""
    return condition(rng, scenario(rng, n))


def scenario_draw(scenario: Callable[[np.random.Generator, int], Any],
                  condition: Callable[[np.random.Generator, Any], tuple[Any, Any]]) -> Callable[..., tuple[Any, Any]]:
    """The ``draw(rng, n)`` of :func:`run_study` for a scenario under an error condition (see :func:`compare`).

    ``scenario(rng, n_runs)`` (called with ``n_runs`` by position) makes that many runs of a geometry (true tracks,
    beacon, DR); ``condition(rng, runs)`` measures them under an error model and returns ``(inputs, truth)``. The
    result is a ``functools.partial`` of a module-level function, so it can be sent to a process pool when
    ``scenario`` and ``condition`` can.

    Examples
    --------
    The common suite's circle under white range noise, two runs:

    >>> import numpy as np
    >>> from uwtutor.montecarlo import scenario_draw
    >>> from uwtutor.scenarios import suite
    >>> draw = scenario_draw(suite.circle, suite.white)
    >>> inputs, truth = draw(np.random.default_rng(0), 2)
    >>> type(inputs).__name__, truth.shape
    ('SuiteInputs', (2, 150, 2))
    """
    import functools

    for name, fn in (("scenario", scenario), ("condition", condition)):
        if not callable(fn):
            raise TypeError(f"{name} must be a function; got {fn!r}")
    return functools.partial(_scenario_condition_draw, scenario, condition)


_TEXT_COLUMNS = ("method", "scenario", "condition")


_NUMBER_COLUMNS = ("n_runs", "n_steps", "final_rmse", "median_final_error", "p95_final_error", "mean_rmse",
                   "final_bound", "mean_bound", "efficiency", "final_efficiency", "mean_nees", "nees_fraction",
                   "divergence_threshold", "divergence_fraction")


_TIMING_COLUMNS = ("cost_per_step",)


#: The intervals of :mod:`uwtutor.statistics` (after the timing column: the older columns keep their places).
_INTERVAL_COLUMNS = ("n_lost", "final_rmse_lower", "final_rmse_upper", "median_final_error_lower",
                     "median_final_error_upper", "converged_rmse", "converged_rmse_lower", "converged_rmse_upper",
                     "divergence_fraction_lower", "divergence_fraction_upper", "median_nees", "median_nees_lower",
                     "median_nees_upper", "nees_median_reference")


_INT_COLUMNS = ("n_runs", "n_steps", "n_lost")


@dataclass(frozen=True)
class ComparisonTable:
    r"""The tidy table of :func:`compare`: one row per (method, scenario, condition), one array per column.

    Every column except ``cost_per_step`` is reproducible: the same seed and chunk size give the same numbers
    on any executor. ``cost_per_step`` is a wall-clock measurement (it changes from run to run and machine to
    machine), kept apart in ``timing_columns``.

    Attributes
    ----------
    method : ndarray of str
        The name of the row's method.
    scenario : ndarray of str
        The name of the row's scenario.
    condition : ndarray of str
        The name of the row's error condition.
    n_runs : ndarray of int
        Monte Carlo runs of the row's study.
    n_steps : ndarray of int
        Steps ``K`` of the row's study.
    final_rmse : ndarray
        :math:`\mathrm{RMSE}_K` [m].
    median_final_error : ndarray
        The median of the final error norm over the runs [m] (robust to the few runs that diverge, which dominate
        the RMSE; a NaN estimate counts as an infinite error).
    p95_final_error : ndarray
        Its 95th percentile [m].
    mean_rmse : ndarray
        :math:`\frac1K\sum_k \mathrm{RMSE}_k` [m].
    final_bound : ndarray
        The supplied RMSE bound :math:`B_K` at the last step (e.g. :math:`\sqrt{\operatorname{tr}}` of the
        posterior CRLB) [m]; NaN without a bound.
    mean_bound : ndarray
        :math:`\frac1K\sum_k B_k` [m]; NaN without a bound.
    efficiency : ndarray
        ``mean_rmse / mean_bound``: 1 for an efficient estimator, larger for a worse one; NaN without a bound.
    final_efficiency : ndarray
        ``final_rmse / final_bound``.
    mean_nees : ndarray
        The mean NEES averaged over the steps (the scored components' count for a consistent filter).
    nees_fraction : ndarray
        Fraction of the steps whose mean NEES lies inside its chi-square interval (about the confidence if the
        filter is consistent).
    divergence_threshold : ndarray
        The final-error threshold of the row [m].
    divergence_fraction : ndarray
        The fraction of the row's runs whose final error is above it (or NaN).
    cost_per_step : ndarray
        Wall-clock seconds per run and step of the method on one batch (not reproducible).
    n_lost : ndarray of int
        Runs lost (final error above the threshold, or NaN).
    final_rmse_lower : ndarray
        Interval of ``final_rmse`` (:func:`uwtutor.statistics.final_rmse_interval`); NaN where it is not estimable
        (fewer than ``uwtutor.statistics.MIN_LOST_FOR_RMSE`` lost runs: the RMSE rests on them).
    final_rmse_upper : ndarray
        Interval of ``final_rmse`` (:func:`uwtutor.statistics.final_rmse_interval`); NaN where it is not estimable
        (fewer than ``uwtutor.statistics.MIN_LOST_FOR_RMSE`` lost runs: the RMSE rests on them).
    median_final_error_lower : ndarray
        Distribution-free interval of the median.
    median_final_error_upper : ndarray
        Distribution-free interval of the median.
    converged_rmse : ndarray
        RMSE of the runs within the threshold, with its interval [m].
    converged_rmse_lower : ndarray
        RMSE of the runs within the threshold, with its interval [m].
    converged_rmse_upper : ndarray
        RMSE of the runs within the threshold, with its interval [m].
    divergence_fraction_lower : ndarray
        Wilson interval of the lost fraction.
    divergence_fraction_upper : ndarray
        Wilson interval of the lost fraction.
    median_nees : ndarray
        Median over the runs of the final NEES, with its interval (NaN for a method with no covariance).
    median_nees_lower : ndarray
        Median over the runs of the final NEES, with its interval (NaN for a method with no covariance).
    median_nees_upper : ndarray
        Median over the runs of the final NEES, with its interval (NaN for a method with no covariance).
    nees_median_reference : ndarray
        The median of :math:`\chi^2_d` it is compared with (1.39 for the position, d = 2).
    seed : int
        Root seed of every study of the table.
    chunk_size : int
        Runs per chunk of every study.
    confidence : float
        Probability of the NEES intervals.
    versions : dict of str
        Versions that computed the table.
    rmse_curves : ndarray or None
        :math:`\mathrm{RMSE}_k` of every row over the steps, one row per table row and one column per step (when
        all rows have the same ``K``); saved with :meth:`to_npz`, not in the CSV.
    bound_curves : ndarray or None
        The supplied bound :math:`B_k` of every row, the same shape (NaN in rows without one).
    final_errors : ndarray or None
        Final error of every run, one row per table row ``(rows, n_runs)`` [m]: the runs are the same for every
        method of a (scenario, condition), so two rows are compared **paired** (:meth:`paired`). Saved with
        :meth:`to_runs_npz`.
    final_nees : ndarray or None
        Final NEES of every run, the same shape.

    Examples
    --------
    Chapter 10's committed table (``uwtutor.methods.load_comparison``), one row per (method, scenario, condition):

    >>> from uwtutor.methods import load_comparison
    >>> table = load_comparison()
    >>> row = table.row("EKF", "circle", "white")
    >>> row["n_runs"], row["scenario"], bool(row["final_rmse"] > 0)
    (1000, 'circle', True)
    >>> table.timing_columns
    ('cost_per_step',)
    """

    method: np.ndarray
    scenario: np.ndarray
    condition: np.ndarray
    n_runs: np.ndarray
    n_steps: np.ndarray
    final_rmse: np.ndarray
    median_final_error: np.ndarray
    p95_final_error: np.ndarray
    mean_rmse: np.ndarray
    final_bound: np.ndarray
    mean_bound: np.ndarray
    efficiency: np.ndarray
    final_efficiency: np.ndarray
    mean_nees: np.ndarray
    nees_fraction: np.ndarray
    divergence_threshold: np.ndarray
    divergence_fraction: np.ndarray
    cost_per_step: np.ndarray
    n_lost: np.ndarray
    final_rmse_lower: np.ndarray
    final_rmse_upper: np.ndarray
    median_final_error_lower: np.ndarray
    median_final_error_upper: np.ndarray
    converged_rmse: np.ndarray
    converged_rmse_lower: np.ndarray
    converged_rmse_upper: np.ndarray
    divergence_fraction_lower: np.ndarray
    divergence_fraction_upper: np.ndarray
    median_nees: np.ndarray
    median_nees_lower: np.ndarray
    median_nees_upper: np.ndarray
    nees_median_reference: np.ndarray
    seed: int
    chunk_size: int
    confidence: float
    versions: dict[str, str]
    rmse_curves: np.ndarray | None = None
    bound_curves: np.ndarray | None = None
    final_errors: np.ndarray | None = None
    final_nees: np.ndarray | None = None

    #: The columns, in order.
    columns = _TEXT_COLUMNS + _NUMBER_COLUMNS + _TIMING_COLUMNS + _INTERVAL_COLUMNS
    #: The columns that are the same on every machine and executor for the same seed and chunk size.
    reproducible_columns = _TEXT_COLUMNS + _NUMBER_COLUMNS + _INTERVAL_COLUMNS
    #: The wall-clock columns (not reproducible).
    timing_columns = _TIMING_COLUMNS

    def __len__(self) -> int:
        return len(self.method)

    def _row(self, i: int) -> dict[str, Any]:
        return {c: (str(v) if c in _TEXT_COLUMNS else (int(v) if c in _INT_COLUMNS else float(v)))
                for c in self.columns for v in (getattr(self, c)[i],)}

    def rows(self) -> list[dict[str, Any]]:
        """The table as a list of rows, each a dict column -> value (plain Python str, int and float)."""
        return [self._row(i) for i in range(len(self))]

    def index(self, method: str, scenario: str, condition: str) -> int:
        """The position of the row of one (method, scenario, condition); a KeyError if the table has none."""
        hit = np.flatnonzero((self.method == method) & (self.scenario == scenario) & (self.condition == condition))
        if hit.size == 0:
            raise KeyError(f"no row for method {method!r}, scenario {scenario!r}, condition {condition!r}")
        return int(hit[0])

    def row(self, method: str, scenario: str, condition: str) -> dict[str, Any]:
        """The row of one (method, scenario, condition)."""
        return self._row(self.index(method, scenario, condition))

    def to_markdown(self, columns: Any = None, digits: int = 3) -> str:
        """The table as a Markdown pipe table (for a notebook's ``IPython.display.Markdown``).

        ``columns`` chooses and orders the columns (all the reproducible ones by default: a timing printed in a
        notebook would change its output on every run); floats get ``digits`` significant digits.
        """
        cols = tuple(self.reproducible_columns if columns is None else columns)
        unknown = [c for c in cols if c not in self.columns]
        if unknown:
            raise ValueError(f"unknown column(s) {unknown}; the columns are {list(self.columns)}")
        digits = as_int("digits", digits, minimum=1)
        lines = ["| " + " | ".join(cols) + " |",
                 "|" + "|".join(":---" if c in _TEXT_COLUMNS else "---:" for c in cols) + "|"]
        for r in self.rows():
            cells = [f"{r[c]:.{digits}g}" if isinstance(r[c], float) else str(r[c]) for c in cols]
            lines.append("| " + " | ".join(cells) + " |")
        return "\n".join(lines) + "\n"

    def to_csv(self, path: Any, *, overwrite: bool = False) -> None:
        """Write the table as CSV, its seed, chunk size, confidence and versions in ``#`` comment lines first.

        Floats are written with ``repr`` (they read back exactly). An existing file is not replaced unless
        ``overwrite=True``.
        """
        import csv
        import json
        from pathlib import Path

        p = Path(path)
        if p.exists() and not overwrite:
            raise FileExistsError(f"{p} exists; pass overwrite=True to replace it")
        meta = {"seed": self.seed, "chunk_size": self.chunk_size, "confidence": self.confidence,
                "versions": self.versions}
        with p.open("w", newline="", encoding="utf-8") as fh:
            fh.write("# uwtutor.montecarlo.compare table\n")
            fh.write(f"# {json.dumps(meta, sort_keys=True)}\n")
            writer = csv.writer(fh, lineterminator="\n")
            writer.writerow(self.columns)
            for r in self.rows():
                writer.writerow([repr(v) if isinstance(v, float) else v for v in r.values()])

    def curves(self, method: str, scenario: str,
               condition: str) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(rmse, bound)`` over the steps of one row (``rmse_curves`` and ``bound_curves``)."""
        if self.rmse_curves is None or self.bound_curves is None:
            raise ValueError("this table holds no curves: read it with from_csv(path, curves=npz_path)")
        i = self.index(method, scenario, condition)
        return self.rmse_curves[i], self.bound_curves[i]

    def to_npz(self, path: Any, *, overwrite: bool = False) -> None:
        """Write ``rmse_curves`` and ``bound_curves`` with the rows' names (``numpy.savez_compressed``); an
        existing file is not replaced unless ``overwrite=True``."""
        from pathlib import Path

        if self.rmse_curves is None or self.bound_curves is None:
            raise ValueError("this table holds no curves (its rows have different numbers of steps)")
        p = Path(path)
        if p.exists() and not overwrite:
            raise FileExistsError(f"{p} exists; pass overwrite=True to replace it")
        with p.open("wb") as fh:
            np.savez_compressed(fh, method=self.method, scenario=self.scenario, condition=self.condition,
                                rmse_curves=self.rmse_curves, bound_curves=self.bound_curves)

    def to_runs_npz(self, path: Any, *, overwrite: bool = False) -> None:
        """Write every row's per-run ``final_errors`` and ``final_nees`` (float32, keys ``final_error`` and
        ``final_nees``) with the rows' names; an existing file is not replaced unless ``overwrite=True``."""
        from pathlib import Path

        if self.final_errors is None or self.final_nees is None:
            raise ValueError("this table holds no runs (its rows have different numbers of runs, or it was read "
                             "without runs=)")
        p = Path(path)
        if p.exists() and not overwrite:
            raise FileExistsError(f"{p} exists; pass overwrite=True to replace it")
        with p.open("wb") as fh:
            np.savez_compressed(fh, method=self.method, scenario=self.scenario, condition=self.condition,
                                final_error=self.final_errors.astype(np.float32),
                                final_nees=self.final_nees.astype(np.float32))

    @classmethod
    def concatenate(cls, tables: Any) -> "ComparisonTable":
        """One table from several with the same seed, chunk size and confidence, their rows in the given order (the
        studies of :func:`compare` are independent row by row: a table computed in parts is the whole one).

        Examples
        --------
        >>> from uwtutor.methods import load_comparison
        >>> from uwtutor.montecarlo import ComparisonTable
        >>> t = load_comparison()
        >>> len(ComparisonTable.concatenate([t, t])) == 2 * len(t)
        True
        """
        parts = list(tables)
        if not parts or not all(isinstance(t, cls) for t in parts):
            raise TypeError("tables must be a non-empty sequence of ComparisonTable")
        first = parts[0]
        for t in parts[1:]:
            if (t.seed, t.chunk_size, t.confidence) != (first.seed, first.chunk_size, first.confidence):
                raise ValueError("tables must share seed, chunk_size and confidence to be one table; got "
                                 f"{(t.seed, t.chunk_size, t.confidence)} and "
                                 f"{(first.seed, first.chunk_size, first.confidence)}")
        cols = {c: np.concatenate([getattr(t, c) for t in parts]) for c in cls.columns}
        extra: dict[str, Any] = {}
        for name in ("rmse_curves", "bound_curves", "final_errors", "final_nees"):
            arrays = [getattr(t, name) for t in parts]
            if all(a is not None for a in arrays) and len({a.shape[1:] for a in arrays}) == 1:
                extra[name] = np.concatenate(arrays)
        return cls(**cols, seed=first.seed, chunk_size=first.chunk_size, confidence=first.confidence,
                   versions=first.versions, **extra)

    # -- verdicts: every comparison paired on the same runs (uwtutor.statistics) ------------------------------------
    def _runs(self) -> tuple[np.ndarray, np.ndarray]:
        if self.final_errors is None or self.final_nees is None:
            raise ValueError("this table holds no runs: read it with from_csv(path, runs=npz_path) "
                             "(uwtutor.methods.load_comparison() does)")
        return self.final_errors, self.final_nees

    def methods_in(self, scenario: str, condition: str) -> list[str]:
        """The methods with a row in the cell (scenario, condition), in the table's order."""
        return [str(m) for m in self.method[(self.scenario == scenario) & (self.condition == condition)]]

    def cell_errors(self, scenario: str, condition: str, methods: Any = None) -> dict[str, np.ndarray]:
        """``method -> final errors`` of a (scenario, condition): the same runs for every method."""
        errors, _ = self._runs()
        names = self.methods_in(scenario, condition) if methods is None else list(methods)
        if not names:
            raise KeyError(f"no row for scenario {scenario!r}, condition {condition!r}")
        return {m: errors[self.index(m, scenario, condition)] for m in names}

    def cell_statistics(self, method: str, scenario: str, condition: str) -> Any:
        """Every number of one row with its interval (:class:`uwtutor.statistics.CellStatistics`)."""
        from ..statistics import cell_statistics

        errors, nees = self._runs()
        i = self.index(method, scenario, condition)
        return cell_statistics(errors[i], nees[i], threshold=float(self.divergence_threshold[i]),
                               confidence=self.confidence)

    def paired(self, a: str, b: str, scenario: str, condition: str, *, seed: int = 0) -> Any:
        """Method ``a`` minus method ``b`` on the same runs of a cell (:func:`uwtutor.statistics.paired_comparison`)."""
        from ..statistics import paired_comparison

        errors, _ = self._runs()
        i, j = self.index(a, scenario, condition), self.index(b, scenario, condition)
        return paired_comparison(errors[i], errors[j], names=(a, b), threshold=float(self.divergence_threshold[i]),
                                 confidence=self.confidence, seed=seed)

    def ranking(self, scenario: str, condition: str, criterion: str = "median", methods: Any = None, *,
                seed: int = 0) -> Any:
        """The methods of a cell ordered by ``criterion`` where the paired intervals allow it
        (:func:`uwtutor.statistics.rank`; ``methods`` chooses some)."""
        from ..statistics import rank

        cell = self.cell_errors(scenario, condition, methods)
        thr = float(self.divergence_threshold[self.index(next(iter(cell)), scenario, condition)])
        return rank(cell, criterion, threshold=thr, confidence=self.confidence, seed=seed)

    def best(self, scenario: str, condition: str, limit: float = 0.05, *, seed: int = 0) -> "BestInCell":
        """The best methods of a cell by median final error, among those whose lost fraction is clearly below
        ``limit`` (Wilson interval), with the ties and the methods whose lost fraction is undecided.

        Examples
        --------
        >>> from uwtutor.methods import load_comparison
        >>> best = load_comparison().best("moving beacon", "white")
        >>> "particle filter" in best.best and "EKF" in best.best
        True
        """
        from ..statistics import lost_verdict, rank

        verdicts = {m: lost_verdict(int(self.n_lost[self.index(m, scenario, condition)]),
                                    int(self.n_runs[self.index(m, scenario, condition)]), limit, self.confidence)
                    for m in self.methods_in(scenario, condition)}
        eligible = [m for m, v in verdicts.items() if v == "clearly below"]
        ranking = None
        if eligible:
            ranking = rank(self.cell_errors(scenario, condition, eligible), "median",
                           threshold=float(self.divergence_threshold[self.index(eligible[0], scenario, condition)]),
                           confidence=self.confidence, seed=seed)
        return BestInCell(scenario, condition, limit, verdicts, ranking)

    @classmethod
    def from_csv(cls, path: Any, curves: Any = None, runs: Any = None) -> "ComparisonTable":
        """Read a table written by :meth:`to_csv` (its curves, written by :meth:`to_npz`, from ``curves``; its runs,
        written by :meth:`to_runs_npz`, from ``runs``). A table written before the interval columns reads with
        them NaN (``n_lost`` -1)."""
        import csv
        import json
        from pathlib import Path

        lines = Path(path).read_text(encoding="utf-8").splitlines()
        comments = [ln[1:].strip() for ln in lines if ln.startswith("#")]
        meta = next((json.loads(c) for c in comments if c.startswith("{")), None)
        if meta is None:
            raise ValueError(f"{path} is not a table written by ComparisonTable.to_csv (no metadata line)")
        records = list(csv.reader(ln for ln in lines if not ln.startswith("#")))
        header, body = records[0], records[1:]
        older = _TEXT_COLUMNS + _NUMBER_COLUMNS + _TIMING_COLUMNS       # a table written before the intervals
        if tuple(header) not in (cls.columns, older):
            raise ValueError(f"{path} has columns {header}; expected {list(cls.columns)}")
        cols: dict[str, Any] = {}
        for j, c in enumerate(header):
            values = [r[j] for r in body]
            if c in _TEXT_COLUMNS:
                cols[c] = np.array(values, dtype=str)
            elif c in _INT_COLUMNS:
                cols[c] = np.array([int(v) for v in values], dtype=int)
            else:
                cols[c] = np.array([float(v) for v in values])
        for c in cls.columns:
            if c not in cols:                                           # the older table: intervals unknown
                cols[c] = np.full(len(body), -1 if c in _INT_COLUMNS else np.nan)
        extra: dict[str, Any] = {}
        if curves is not None:
            with np.load(curves) as data:
                for name in _TEXT_COLUMNS:
                    if not np.array_equal(data[name].astype(str), cols[name]):
                        raise ValueError(f"{curves} does not hold the rows of {path} (its {name} column differs)")
                extra = dict(rmse_curves=np.array(data["rmse_curves"]), bound_curves=np.array(data["bound_curves"]))
        if runs is not None:
            with np.load(runs) as data:
                for name in _TEXT_COLUMNS:
                    if not np.array_equal(data[name].astype(str), cols[name]):
                        raise ValueError(f"{runs} does not hold the rows of {path} (its {name} column differs)")
                extra.update(final_errors=np.array(data["final_error"], dtype=float),
                             final_nees=np.array(data["final_nees"], dtype=float))
        return cls(**cols, seed=int(meta["seed"]), chunk_size=int(meta["chunk_size"]),
                   confidence=float(meta["confidence"]), versions=dict(meta["versions"]), **extra)


@dataclass(frozen=True)
class BestInCell:
    """The best methods of one (scenario, condition) of a :class:`ComparisonTable` (see :meth:`ComparisonTable.best`).

    Attributes
    ----------
    scenario : str
    condition : str
    limit : float
        The lost fraction a method must be clearly below to be eligible.
    lost_verdicts : dict
        ``method -> "clearly below" | "clearly above" | "undecided"`` against ``limit``.
    ranking : uwtutor.statistics.Ranking or None
        The eligible methods by median final error (None if none is eligible).

    Examples
    --------
    >>> from uwtutor.methods import load_comparison
    >>> cell = load_comparison().best("line", "bias")
    >>> cell.lost_verdicts["IEKF"], cell.best[:1]
    ('clearly below', ('IEKF',))
    """

    scenario: str
    condition: str
    limit: float
    lost_verdicts: dict[str, str]
    ranking: Any

    @property
    def best(self) -> tuple[str, ...]:
        """The leader by median and the eligible methods tied with it (empty if none is eligible)."""
        return () if self.ranking is None else self.ranking.best

    @property
    def undecided(self) -> tuple[str, ...]:
        """Methods whose lost fraction's interval straddles the limit (neither eligible nor excluded)."""
        return tuple(m for m, v in self.lost_verdicts.items() if v == "undecided")

    def runner_up(self) -> tuple[str, Any] | None:
        """The first eligible method clearly behind the best, with the paired interval of the leader minus it."""
        if self.ranking is None:
            return None
        rest = [m for m in self.ranking.order if m not in self.best]
        if not rest:
            return None
        return rest[0], self.ranking.interval(self.ranking.order[0], rest[0])


def _named_callables(name: str, value: Any) -> dict[str, Callable[..., Any]]:
    if not isinstance(value, dict) or not value:
        raise TypeError(f"{name} must be a non-empty dict name -> function; got {type(value).__name__}")
    for key, fn in value.items():
        if not isinstance(key, str):
            raise TypeError(f"{name} must be keyed by names (str); got the key {key!r}")
        if not callable(fn):
            raise TypeError(f"{name}[{key!r}] must be a function; got {fn!r}")
    return value


def _lookup(mapping: Any, scenario: str, condition: str) -> Any:
    """A per-row setting: keyed by (scenario, condition), else by scenario, else None."""
    if mapping is None:
        return None
    if (scenario, condition) in mapping:
        return mapping[(scenario, condition)]
    return mapping.get(scenario)


def _check_cell_options(methods: dict[str, Any], scenarios: dict[str, Any], conditions: dict[str, Any], only: Any,
                        bounds: Any, divergence_threshold: Any) -> None:
    """``compare``'s ``only``, ``bounds`` and ``divergence_threshold`` name existing methods, scenarios and cells."""
    if only is not None:
        if not isinstance(only, dict):
            raise TypeError(f"only must be a dict method name -> scenario names; got {type(only).__name__}")
        for m, names in only.items():
            if m not in methods:
                raise ValueError(f"only names the method {m!r}, which is not in methods ({list(methods)})")
            unknown = set(names) - set(scenarios)
            if unknown:
                raise ValueError(f"only[{m!r}] names scenarios that are not in scenarios: {sorted(unknown)}")
    for name, mapping in (("bounds", bounds), ("divergence_threshold", divergence_threshold)):
        if isinstance(mapping, dict):
            for key in mapping:
                s = key[0] if isinstance(key, tuple) else key
                c = key[1] if isinstance(key, tuple) and len(key) == 2 else None
                if s not in scenarios or (isinstance(key, tuple) and (len(key) != 2 or c not in conditions)):
                    raise ValueError(f"{name} has the key {key!r}; keys must be scenario names or (scenario, "
                                     "condition) pairs of the given scenarios and conditions")
        elif name == "bounds" and mapping is not None:
            raise TypeError(f"bounds must be a dict keyed by scenario or (scenario, condition); got "
                            f"{type(mapping).__name__}")


def _cell_bound(bound: Any, s_name: str, c_name: str, K: int) -> np.ndarray | None:
    """A cell's bound curve, checked to have the studies' ``K`` steps (None: no bound)."""
    if bound is None:
        return None
    b = as_positive(f"bounds[{s_name!r}]", bound, ndim=1)
    if len(b) != K:
        raise ValueError(f"the bound of scenario {s_name!r}, condition {c_name!r} has {len(b)} "
                         f"steps; the studies have {K}")
    return b


def _row_columns(study: Any, names: tuple[str, str, str], n_runs: int, b: np.ndarray | None, thr: float,
                 cost: float) -> dict[str, Any]:
    """The columns of one row of the table read off a study (the intervals of ``cell_statistics`` come after)."""
    m_name, s_name, c_name = names
    K = study.n_steps
    final_b, mean_b = (float(b[-1]), float(b.mean())) if b is not None else (np.nan, np.nan)
    final_rmse, mean_rmse = float(study.rmse[-1]), float(study.rmse.mean())
    lost = np.where(np.isnan(study.final_errors), np.inf, study.final_errors)   # NaN: diverged
    with np.errstate(invalid="ignore"):
        diverged = ~(study.final_errors <= thr)
    return {"method": m_name, "scenario": s_name, "condition": c_name, "n_runs": n_runs, "n_steps": K,
            "final_rmse": final_rmse, "median_final_error": float(np.median(lost)),
            "p95_final_error": float(np.percentile(lost, 95.0)), "mean_rmse": mean_rmse, "final_bound": final_b,
            "mean_bound": mean_b, "efficiency": mean_rmse / mean_b, "final_efficiency": final_rmse / final_b,
            "mean_nees": float(np.mean(study.mean_nees)),
            "nees_fraction": np.nan if np.isnan(study.mean_nees).all()
            else study.nees_fraction_within(),                                 # no covariance: no NEES
            "divergence_threshold": thr, "divergence_fraction": float(diverged.mean()), "cost_per_step": cost}


def _as_table(cols: dict[str, list[Any]], curves: list[tuple[np.ndarray, np.ndarray]],
              runs: list[tuple[np.ndarray, np.ndarray | None]], *, seed: int, chunk_size: int, confidence: float,
              versions: dict[str, str]) -> ComparisonTable:
    """The table of the collected columns (typed), with the curves and final errors when every cell has as many."""
    arrays: dict[str, Any] = {}
    for c, values in cols.items():
        if c in _TEXT_COLUMNS:
            arrays[c] = np.array(values, dtype=str)
        elif c in _INT_COLUMNS:
            arrays[c] = np.array(values, dtype=int)
        else:
            arrays[c] = np.array(values, dtype=float)
    same_k = len({len(r) for r, _ in curves}) == 1
    same_n = len({len(e) for e, _ in runs}) == 1
    return ComparisonTable(**arrays, seed=seed, chunk_size=chunk_size, confidence=confidence,
                           versions=versions,
                           rmse_curves=np.array([r for r, _ in curves]) if same_k else None,
                           bound_curves=np.array([b for _, b in curves]) if same_k else None,
                           final_errors=np.array([e for e, _ in runs]) if same_n else None,
                           final_nees=np.array([v for _, v in runs]) if same_n else None)


def compare(methods: dict[str, Callable[[Any], FilterResult]], scenarios: dict[str, Callable[..., Any]],
            conditions: dict[str, Callable[..., Any]], n_runs: int, seed: int, executor: Any = None, *,
            chunk_size: int = 1000, bounds: Any = None, divergence_threshold: Any = DEFAULT_DIVERGENCE_THRESHOLD,
            components: Any = (0, 1), confidence: float = 0.95, only: Any = None,
            measure_cost: bool = True, timing_runs: int | None = None) -> ComparisonTable:
    r"""Every method on every scenario under every error condition: one :func:`run_study` per row of a table.

    For each scenario, each condition and each method (in the dicts' order) the study draws ``n_runs`` runs
    with ``draw = scenario_draw(scenario, condition)`` and filters them with the method, from the same
    ``seed``: all the methods of a (scenario, condition) see **the same runs** (common random numbers), so
    their differences are the methods', not the draws'. Each row reports

    * accuracy: :math:`\mathrm{RMSE}_K` and the time average :math:`\frac1K \sum_k \mathrm{RMSE}_k` of the
      position (the scored ``components``);
    * efficiency against a supplied bound :math:`B_k` (e.g. ``rmse_bound(posterior_crlb(...))``, the
      square root of the trace of the posterior CRLB): :math:`\bar{\mathrm{RMSE}} / \bar B` and
      :math:`\mathrm{RMSE}_K / B_K`, 1 for an efficient estimator;
    * consistency: the fraction of the steps whose mean NEES lies inside its chi-square interval;
    * divergence: the fraction of runs whose final position error exceeds ``divergence_threshold``
      (NaN estimates count as diverged). The default, 50 m, is an order of magnitude above what a filter
      that has converged reaches with metre-level ranges and decimetre-level dead reckoning, and well below the
      hundreds of metres of a mirror solution or a lost track at the book's ranges to the beacon: a run
      above it has not merely been unlucky. Set it per scenario when the geometry calls for another scale.
    * cost: wall-clock seconds per run and step of ``method(inputs)`` on one batch of ``timing_runs`` runs
      drawn and filtered in this process after the study; not reproducible, and kept out of the other
      columns (``ComparisonTable.timing_columns``).

    Parameters
    ----------
    methods : dict of str to callable
        ``name -> method``; a method is ``method(inputs) -> FilterResult``, batched over the runs.
    scenarios : dict of str to callable
        ``name -> scenario``; ``scenario(rng, n_runs)`` (``n_runs`` given by position) makes that many runs of a
        geometry (any object: tracks, beacon, DR displacements...).
    conditions : dict of str to callable
        ``name -> condition``; ``condition(rng, runs)`` measures a scenario's runs under an error model and
        returns ``(inputs, truth)``, as a ``draw`` of :func:`run_study` does.
    n_runs : int
        Monte Carlo runs per row.
    seed : int
        Root seed of every study.
    executor : concurrent.futures.Executor-like, optional
        Passed to :func:`run_study` (a process pool, a Dask cluster); ``None`` runs here.
    chunk_size : int, default 1000
        Runs per chunk.
    bounds : dict, optional
        RMSE bounds :math:`B_k`, shape ``(K,)`` [m], keyed by ``(scenario, condition)`` or by scenario.
    divergence_threshold : float or dict, default ``DEFAULT_DIVERGENCE_THRESHOLD`` (50 m)
        Final error [m] above which a run has diverged; or a dict keyed like ``bounds``.
    components : sequence of int, default (0, 1)
        The scored state components (the position comes first in every state of the library).
    confidence : float, default 0.95
        Probability of the NEES intervals.
    only : dict of str to collection of str, optional
        ``method name -> the scenario names it runs on`` (e.g. a cooperative filter needs a leader); the
        other methods run on every scenario.
    measure_cost : bool, default True
        Measure ``cost_per_step`` (NaN otherwise).
    timing_runs : int, optional
        Runs in the timing batch; ``min(n_runs, chunk_size)`` by default.

    Returns
    -------
    ComparisonTable

    Examples
    --------
    The range-only EKF on a circle and on a straight line, with white range noise and with a 5 m range bias
    (the functions are module-level in real code, so that a process pool can pickle them):

    >>> import numpy as np
    >>> from uwtutor.filters import range_only_ekf
    >>> from uwtutor.montecarlo import compare
    >>> K = 150
    >>> # n runs of a track: (n, K + 1, 2), x0 first
    >>> def circle(rng, n):
    ...     t = np.linspace(0.0, np.pi, K + 1)
    ...     return np.broadcast_to(
    ...         300.0 * np.column_stack([np.cos(t), np.sin(t)]), (n, K + 1, 2)
    ...     )
    >>> def line(rng, n):
    ...     xy = np.column_stack(
    ...         [np.linspace(-300.0, 300.0, K + 1), np.full(K + 1, 150.0)]
    ...     )
    ...     return np.broadcast_to(xy, (n, K + 1, 2))
    >>> def measured(bias):
    ...     def condition(rng, tracks):
    ...         n, truth = len(tracks), tracks[:, 1:]
    ...         z = (
    ...             np.linalg.norm(truth, axis=-1)
    ...             + bias
    ...             + rng.normal(0.0, 2.0, (n, K))
    ...         )
    ...         x0 = tracks[:, 0] + rng.normal(0.0, 5.0, (n, 2))
    ...         return dict(x0=x0, z=z, u=np.diff(tracks, axis=1)), truth
    ...
    ...     return condition
    >>> def ekf(inputs):
    ...     return range_only_ekf(
    ...         inputs["x0"],
    ...         25.0 * np.eye(2),
    ...         inputs["u"],
    ...         inputs["z"],
    ...         0.01 * np.eye(2),
    ...         4.0,
    ...     )
    >>> table = compare(
    ...     {"EKF": ekf},
    ...     {"circle": circle, "line": line},
    ...     {"white": measured(0.0), "bias 5 m": measured(5.0)},
    ...     n_runs=400,
    ...     seed=1,
    ...     chunk_size=400,
    ...     measure_cost=False,
    ... )
    >>> len(table), table.columns[:4]
    (4, ('method', 'scenario', 'condition', 'n_runs'))
    >>> for r in table.rows():
    ...     print(
    ...         f"{r['scenario']:6s} {r['condition']:8s} "
    ...         f"final RMSE {r['final_rmse']:5.1f} m"
    ...     )
    circle white    final RMSE   0.5 m
    circle bias 5 m final RMSE   6.5 m
    line   white    final RMSE   0.4 m
    line   bias 5 m final RMSE   6.6 m
    """
    method_of = _named_callables("methods", methods)
    scenarios = _named_callables("scenarios", scenarios)
    conditions = _named_callables("conditions", conditions)
    n_runs = as_int("n_runs", n_runs, minimum=1)
    chunk_size = as_int("chunk_size", chunk_size, minimum=1)
    seed = as_int("seed", seed, minimum=0)
    if timing_runs is not None:
        timing_runs = as_int("timing_runs", timing_runs, minimum=1)
    _check_cell_options(method_of, scenarios, conditions, only, bounds, divergence_threshold)

    from ..statistics import cell_statistics

    cols: dict[str, list[Any]] = {c: [] for c in ComparisonTable.columns}
    curves: list[tuple[np.ndarray, np.ndarray]] = []
    runs: list[tuple[np.ndarray, np.ndarray | None]] = []
    versions: dict[str, str] = {}
    for s_name, scenario in scenarios.items():
        for c_name, condition in conditions.items():
            draw = scenario_draw(scenario, condition)
            bound = _lookup(bounds, s_name, c_name)
            thr = divergence_threshold if not isinstance(divergence_threshold, dict) else \
                _lookup(divergence_threshold, s_name, c_name)
            thr = DEFAULT_DIVERGENCE_THRESHOLD if thr is None else float(as_positive("divergence_threshold", thr))
            for m_name, method in method_of.items():
                if only is not None and m_name in only and s_name not in only[m_name]:
                    continue
                study = run_study(draw, method, n_runs, seed=seed, chunk_size=chunk_size, executor=executor,
                                  components=components, confidence=confidence)
                versions = study.versions
                b = _cell_bound(bound, s_name, c_name, study.n_steps)
                curves.append((study.rmse, np.full(study.n_steps, np.nan) if b is None else b))
                cost = np.nan
                if measure_cost:
                    cost = _cost_per_step(draw, method, timing_runs or min(n_runs, chunk_size), seed, study.n_steps)
                row = _row_columns(study, (m_name, s_name, c_name), n_runs, b, thr, cost)
                for key, value in row.items():
                    cols[key].append(value)
                cell = cell_statistics(study.final_errors, study.final_nees, dof=len(study.components),
                                       threshold=thr, confidence=confidence)
                for key, value in cell.as_columns().items():
                    cols[key].append(value)
                runs.append((study.final_errors, study.final_nees))
    if not cols["method"]:
        raise ValueError("no (method, scenario) pair to run: check only")
    return _as_table(cols, curves, runs, seed=seed, chunk_size=chunk_size, confidence=float(confidence),
                     versions=versions)


def _cost_per_step(draw: Callable[..., Any], method: Callable[..., Any], n: int, seed: int, K: int) -> float:
    """Wall-clock seconds per run and step of ``method`` on one batch of ``n`` runs (drawn outside the timing)."""
    import time

    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(2**32 - 1,)))   # not a study stream
    inputs, _ = draw(rng, n)
    start = time.perf_counter()
    method(inputs)
    return (time.perf_counter() - start) / (n * K)
