"""Parameter and speed sweeps: the grid, the runner, the sweep file."""
