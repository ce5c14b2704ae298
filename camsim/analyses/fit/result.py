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
      "residual_variance": float,    # s² of the weighted residuals
      "targets": {NAME: {"value", "sigma", "unit", "achieved"}},  # each --target [SI]
      "matched": bool,               # no misfit (else exit 1 unless --accept-misfit)
      "misfits": [str, ...],         # a --target missed by > sigma; s² > MISFIT_VARIANCE
      "warnings": [str, ...]         # identifiability and data warnings, one line each
    }
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["FitResult", "MISFIT_VARIANCE"]

#: Residual variance s² above which a fit to measured traces "did not match": the weighted
#: residuals are then on average more than sqrt(2) = 1.41 times the noise level. With the right
#: noise levels and a model that fits, s² is 1 within sqrt(2/dof) (docs/fitting.md).
MISFIT_VARIANCE = 2.0


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
    targets: dict[str, dict[str, Any]] = field(default_factory=dict)

    @property
    def misfits(self) -> list[str]:
        """Why the fitted machine does not match (empty when it does): one line per missed
        ``--target`` (|achieved - target| > its sigma) and, for a fit to measured traces, a
        residual variance above :data:`MISFIT_VARIANCE`, each with its figures [SI]."""
        out = []
        for name, t in self.targets.items():
            error = t["achieved"] - t["value"]
            if not math.isfinite(error) or abs(error) > t["sigma"]:
                unit = f" {t['unit']}" if t["unit"] else ""
                out.append(
                    f"{name}: fitted {t['achieved']:.6g}{unit}, target {t['value']:.6g}{unit} ± {t['sigma']:.3g} "
                    f"(missed by {abs(error) / t['sigma']:.3g} sigma)"
                )
        if self.channels and math.isfinite(self.residual_variance) and self.residual_variance > MISFIT_VARIANCE:
            out.append(
                f"residual variance {self.residual_variance:.4g} > {MISFIT_VARIANCE:g}: the residuals are "
                f"{math.sqrt(self.residual_variance):.3g} times the noise level (RMS); the model does not fit the traces"
            )
        return out

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
            "residual_variance": float(self.residual_variance),
            "targets": {k: dict(v) for k, v in self.targets.items()},
            "matched": not self.misfits,
            "misfits": self.misfits,
            "warnings": list(self.warnings),
        }
