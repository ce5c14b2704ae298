"""Analyses built on runs: comparisons, sweeps, studies, fits, lumping, modes, regression checks, export."""
