"""``python -m camsim`` does what the ``camsim`` command does."""

from camsim.cli import main

main()
