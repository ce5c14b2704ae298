"""Figures from camsim results (matplotlib): runs, comparisons, sweeps, cam design, studies, fits."""
