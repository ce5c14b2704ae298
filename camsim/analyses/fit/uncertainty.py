"""Standard errors, 95 % intervals, correlations and identifiability of a least-squares fit.

Linearised statistics at the optimum. With the weighted residuals r (m of them), the
Jacobian J = dr/dz with respect to the parameters z (the value in SI, or its natural
logarithm for a log-scale parameter) and n parameters:

* residual variance s² = Σ r² / (m − n) — the fit's own estimate of how large the
  weighted residuals are, so a wrong noise level scales the intervals back to honesty
  (s² ≈ 1 when the sigmas are right and the model fits);
* covariance C = s² (JᵀJ)⁻¹ (pseudo-inverse, see below); standard error √C_ii;
* 95 % interval z ± t₀.₉₇₅(m − n)·√C_ii with Student's t (for a log parameter the interval
  of ln x mapped back by exp, so it is not symmetric; its standard error is x·√C_ii by
  the delta method);
* correlation C_ij / √(C_ii C_jj).

A parameter is reported as not identifiable from the data when

* the Jacobian is near-singular: its condition number, with every column scaled to unit
  length (so that units do not matter), exceeds :data:`COND_LIMIT`; the parameters with
  a large share (> :data:`SHARE`) in the singular vector of the smallest singular value
  are named; a column of zeros (a parameter that changes nothing) makes C infinite for it;
* its 95 % interval is wider than its bounds;
* two parameters correlate with \\|r\\| > :data:`CORRELATION_LIMIT`.
These intervals rest on the linearisation: they are exact for a model linear in its
parameters with Gaussian noise, and approximate otherwise.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["COND_LIMIT", "CORRELATION_LIMIT", "Uncertainty", "uncertainty"]

#: Condition number of the column-scaled Jacobian above which it counts as near-singular.
COND_LIMIT = 1e4
#: |correlation| above which two parameters are reported as not separately identifiable.
CORRELATION_LIMIT = 0.95
#: Share of a parameter in the weakest singular vector for it to be named.
SHARE = 0.1
#: Relative singular value below which a direction has no information at all.
RANK_TOL = 1e-12


@dataclass
class Uncertainty:
    """Linearised statistics of a fit (values in SI; see the module docstring).

    Attributes
    ----------
    stderr : ndarray (n,)
        Standard errors [SI] (inf where the data carry no information).
    ci95 : ndarray (n, 2)
        95 % intervals [SI].
    correlation : ndarray (n, n)
    covariance : ndarray (n, n)
        Of the natural coordinates (SI value, or ln of a log parameter).
    condition : float
        Condition number of the column-scaled Jacobian.
    residual_variance : float
        s² (1.0 when there are no degrees of freedom; then the sigmas are taken as given).
    dof : int
        m − n.
    warnings : list of str
    """

    stderr: np.ndarray
    ci95: np.ndarray
    correlation: np.ndarray
    covariance: np.ndarray
    condition: float
    residual_variance: float
    dof: int
    warnings: list[str]


def uncertainty(
    jac: np.ndarray,
    residuals: np.ndarray,
    keys: Sequence[str],
    values: np.ndarray,
    log: Sequence[bool],
    bounds: Sequence[tuple[float, float]],
) -> Uncertainty:
    """Statistics of a least-squares optimum.

    Parameters
    ----------
    jac : ndarray (m, n)
        d(weighted residual)/dz, z the SI value or its ln for a log parameter.
    residuals : ndarray (m,)
        Weighted residuals at the optimum.
    keys : sequence of str
        Parameter names (for the warnings).
    values : ndarray (n,)
        Fitted values [SI].
    log : sequence of bool
        Which parameters are on a log scale.
    bounds : sequence of (float, float)
        Each parameter's bounds [SI].

    Returns
    -------
    Uncertainty
    """
    from scipy import stats

    jac = np.asarray(jac, dtype=float)
    m, n = jac.shape
    warnings: list[str] = []
    dof = m - n
    if dof > 0:
        s2 = float(residuals @ residuals) / dof
    else:
        s2 = 1.0
        warnings.append(
            f"{m} residuals for {n} parameters: no degrees of freedom left to estimate the noise; "
            "the intervals take the given sigmas as exact"
        )
    norms = np.linalg.norm(jac, axis=0)
    dead = [keys[i] for i in range(n) if not norms[i] > 0]
    for k in dead:
        warnings.append(f"{k}: not identifiable: changing it does not change the residuals at all")
    safe = np.where(norms > 0, norms, 1.0)
    js = jac / safe
    _, sv, vt = np.linalg.svd(js, full_matrices=False)
    smin = sv[-1] if sv.size else 0.0
    condition = math.inf if not smin > 0 or dead else float(sv[0] / smin)
    if n > 1 and not dead and condition > COND_LIMIT:
        share = vt[-1] ** 2
        names = [keys[i] for i in np.argsort(-share) if share[i] > SHARE]
        warnings.append(
            f"not identifiable: the Jacobian is near-singular (condition number {condition:.3g} > {COND_LIMIT:g} "
            f"with columns scaled to unit norm); the data fix only a combination of {', '.join(names)}"
        )
    # covariance of the scaled coordinates, then unscaled; directions without information -> inf
    keep = sv > RANK_TOL * (sv[0] if sv.size else 0.0)
    inv = (vt[keep].T / sv[keep] ** 2) @ vt[keep]
    cov = s2 * inv / np.outer(safe, safe)
    var = np.diag(cov).copy()
    lost = vt[~keep]
    for i in range(n):
        if not norms[i] > 0 or (lost.size and np.any(np.abs(lost[:, i]) > 1e-6)):
            var[i] = math.inf
    sd_z = np.sqrt(np.maximum(var, 0.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov / np.sqrt(np.outer(np.diag(cov), np.diag(cov)))
    corr = np.where(np.isfinite(corr), corr, np.nan)
    np.fill_diagonal(corr, 1.0)
    tq = float(stats.t.ppf(0.975, dof)) if dof > 0 else 1.959963984540054
    stderr = np.empty(n)
    ci = np.empty((n, 2))
    for i in range(n):
        x = float(values[i])
        if log[i]:
            stderr[i] = x * sd_z[i]
            ci[i] = (x * math.exp(-tq * sd_z[i]), x * math.exp(tq * sd_z[i])) if math.isfinite(sd_z[i]) else (0.0, math.inf)
        else:
            stderr[i] = sd_z[i]
            ci[i] = (x - tq * sd_z[i], x + tq * sd_z[i])
    for i in range(n):
        lo, hi = bounds[i]
        if keys[i] in dead:
            continue
        if not math.isfinite(stderr[i]) or ci[i, 1] - ci[i, 0] > hi - lo:
            warnings.append(
                f"{keys[i]}: not identifiable: its 95 % interval [{ci[i, 0]:.4g}, {ci[i, 1]:.4g}] is wider than its bounds "
                f"[{lo:.4g}, {hi:.4g}]"
            )
    for i in range(n):
        for j in range(i + 1, n):
            r = corr[i, j]
            if np.isfinite(r) and abs(r) > CORRELATION_LIMIT:
                warnings.append(
                    f"{keys[i]} and {keys[j]}: not separately identifiable: correlation {r:+.4f} "
                    f"(|r| > {CORRELATION_LIMIT}); the data fix mainly a combination of them"
                )
    return Uncertainty(
        stderr=stderr,
        ci95=ci,
        correlation=corr,
        covariance=cov,
        condition=condition,
        residual_variance=s2,
        dof=dof,
        warnings=warnings,
    )
