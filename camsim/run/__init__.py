"""Running a machine: simulation, streamed runs, the run result (the hub every derived quantity comes from) and its files."""
