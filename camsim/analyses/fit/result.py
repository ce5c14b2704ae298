"""The outcome of a fit: :class:`FitResult` and its JSON form (``camsim fit --json``).

JSON schema (every number SI; non-finite numbers are written as null)::

    {
      "parameters": {
        KEY: {"value": float, "unit": str, "stderr": float, "ci95": [lo, hi], "initial": float},
        ...                       # in --param order; "align.offset" [s] with --align offset
      },
      "correlation": [[...], ...],   # n x n, rows and columns in the order of "parameters"
      "cost": float,                 # 1/2 · sum of squared weighted residuals at the optimum
      "rms_residual": {PATH: float, TARGET: float},  # RMS of (simulated - measured) per
                                                      # channel [its SI unit]; |error| of each target
      "n_evaluations": int,          # simulations run (all starts, Jacobians included)
      "converged": bool,
      "warnings": [str, ...]         # identifiability and data warnings, one line each
    }
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["FitResult"]


@dataclass
class FitResult:
    """A calibrated machine: fitted values, their uncertainty and the fit's record.

    Attributes
    ----------
    keys : list of str
        Fitted keys (``--set`` grammar), then ``align.offset`` when a time shift was fitted.
    units : list of str
        SI unit of each.
    values : ndarray
        Fitted values [SI].
    initial : ndarray
        Starting values of the run that won [SI] (the machine file's values unless START
        or a multi-start point was used).
    file_values : ndarray
        The machine's values before the fit [SI] (with ``--set`` applied).
    stderr : ndarray
        Standard errors [SI].
    ci95 : ndarray (n, 2)
        95 % confidence intervals [SI].
    correlation : ndarray (n, n)
    bounds : list of (float, float)
        [SI].
    log : list of bool
    cost : float
        ½ Σ r² of the weighted residuals.
    rms_residual : dict
        Path or target → RMS of the unweighted residual [SI].
    sigma : dict
        Path or target → noise level used for the weighting [SI].
    n_evaluations : int
        Simulations run.
    converged : bool
    message : str
        The solver's last word.
    warnings : list of str
    condition : float
        Condition number of the column-scaled Jacobian at the optimum.
    residual_variance : float
        s² of the weighted residuals.
    dof : int
        Residuals minus parameters.
    starts : list of dict
        One per start: ``start``, ``value`` (SI lists), ``cost``, ``converged``.
    sim_time : ndarray
        Time base of the fitted run [s].
    sim_traces : dict
        Path → fitted run's trace [SI].
    channels : list
        The compared measured channels: (path, measured times [s], measured values [SI],
        fitted simulation at those times [SI]).
    shift : float
        Fitted time shift [s] (0 without ``--align offset``).
    overrides : list of str
        ``KEY=VALUE`` overrides (SI) that reproduce the fitted machine.
    """

    keys: list[str]
    units: list[str]
    values: np.ndarray
    initial: np.ndarray
    file_values: np.ndarray
    stderr: np.ndarray
    ci95: np.ndarray
    correlation: np.ndarray
    bounds: list[tuple[float, float]]
    log: list[bool]
    cost: float
    rms_residual: dict[str, float]
    sigma: dict[str, float]
    n_evaluations: int
    converged: bool
    message: str
    warnings: list[str]
    condition: float = math.nan
    residual_variance: float = math.nan
    dof: int = 0
    starts: list[dict[str, Any]] = field(default_factory=list)
    sim_time: np.ndarray = field(default_factory=lambda: np.zeros(0))
    sim_traces: dict[str, np.ndarray] = field(default_factory=dict)
    channels: list[tuple[str, np.ndarray, np.ndarray, np.ndarray]] = field(default_factory=list)
    shift: float = 0.0
    overrides: list[str] = field(default_factory=list)

    def parameter(self, key: str) -> dict[str, Any]:
        """One parameter's entry of :meth:`to_json`."""
        i = self.keys.index(key)
        return {
            "value": float(self.values[i]),
            "unit": self.units[i],
            "stderr": float(self.stderr[i]),
            "ci95": [float(self.ci95[i, 0]), float(self.ci95[i, 1])],
            "initial": float(self.initial[i]),
        }

    def to_json(self) -> dict[str, Any]:
        """The documented JSON content (see the module docstring); NaN stays NaN here."""
        return {
            "parameters": {k: self.parameter(k) for k in self.keys},
            "correlation": [[float(v) for v in row] for row in np.asarray(self.correlation)],
            "cost": float(self.cost),
            "rms_residual": {k: float(v) for k, v in self.rms_residual.items()},
            "n_evaluations": int(self.n_evaluations),
            "converged": bool(self.converged),
            "warnings": list(self.warnings),
        }
