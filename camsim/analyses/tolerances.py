"""Default tolerances of the regression check (``camsim check``, ``camsim run --check-against``).

A module of their own, free of h5py and numpy, so that the command line can show them in
its help without importing the checker (issue 25, fast start).
"""

#: Default relative tolerance, relative to each dataset's peak |value| (golden file).
DEFAULT_RTOL = 1e-6
#: Default absolute tolerance, in the dataset's SI unit.
DEFAULT_ATOL = 1e-12
