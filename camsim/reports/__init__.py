"""Human-readable output: text summaries on the terminal and the units they are shown in."""
