"""``python -m camsim`` and the ``camsim`` command.

The command line is imported inside :func:`main`, so that Ctrl-C during start-up (the
imports take a few tenths of a second) ends with exit 130 and one line, not a traceback.
"""

import sys


def main() -> None:
    """Console entry point: run the command line; Ctrl-C before it is up exits 130 quietly."""
    try:
        from camsim.cli import main as cli_main
    except KeyboardInterrupt:
        sys.stderr.write("camsim: interrupted; nothing was written\n")
        sys.exit(130)
    cli_main()


if __name__ == "__main__":
    main()
