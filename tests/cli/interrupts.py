"""Child processes that take Ctrl-C as a user's terminal delivers it.

A process started in the background by a non-interactive shell ignores SIGINT (POSIX: bash
sets SIGINT and SIGQUIT to SIG_IGN for asynchronous commands when job control is off), and
the ignored disposition is inherited across fork and exec; Python then installs no
KeyboardInterrupt handler. ``.ci/run`` starts its two test jobs that way, so a camsim child
of a test would ignore the SIGINT the test sends and run to its end (the sweep, study,
optimize, fit and ``impact --materials`` stop tests all failed there, and passed from a
terminal). Tests that deliver SIGINT start their child with :func:`at_a_terminal` as
``preexec_fn``: the child sees the default disposition a terminal's foreground job has.
"""

from __future__ import annotations

import signal


def at_a_terminal() -> None:  # pragma: no cover - runs in the child between fork and exec
    """``preexec_fn``: SIGINT (and SIGQUIT) back to their default dispositions."""
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    signal.signal(signal.SIGQUIT, signal.SIG_DFL)
