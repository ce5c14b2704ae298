"""``python -m camsim`` and the ``camsim`` command.

The command line is imported inside :func:`main`, so that Ctrl-C during start-up (the
imports take a few tenths of a second) ends with exit 130 and one line, not a traceback.
"""

import sys


def main() -> None:
    """Console entry point: run the command line; Ctrl-C before it is up exits 130 quietly."""
    import faulthandler
    import signal

    # A crash in native code (HDF5, BLAS) ends the process with SIGSEGV and, without the
    # fault handler, not one line on stderr: CI once saw `fit --workers 2` die so after
    # SIGTERM, with nothing to say where. It prints the Python stack of every thread first.
    if not faulthandler.is_enabled():  # PYTHONFAULTHANDLER or -X faulthandler: already on
        try:
            faulthandler.enable(all_threads=True)
        except (AttributeError, OSError, RuntimeError, ValueError):  # a stderr without a file descriptor
            pass

    # SIGTERM (a batch system's stop, `kill PID`) takes Ctrl-C's orderly way out everywhere,
    # from start-up to exit, in every command (issue 45): it killed a command outright, with
    # its temporary files, wherever a command had not asked for it.
    signal.signal(signal.SIGTERM, _terminate)
    try:
        from camsim.cli import main as cli_main
    except KeyboardInterrupt:
        _exit_interrupted("camsim: interrupted; nothing was written\n")
    _keep_interrupts()
    from camsim.io.outputs import hold_until_exit

    hold_until_exit()  # the outputs stay locked to the very end of the process (issue 45)
    code: object = 0
    try:
        cli_main()
    except SystemExit as exc:
        code = exc.code
    except KeyboardInterrupt:  # before a command took over (typer building the command line)
        _exit_interrupted("camsim: interrupted; nothing was written\n")
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the command is over: a late Ctrl-C changes nothing
    signal.signal(signal.SIGTERM, signal.SIG_IGN)
    if code == 130:
        _exit_interrupted()
    if code is None:
        code = 0
    elif not isinstance(code, int):
        sys.stderr.write(f"{code}\n")
        code = 1
    _exit(code)


def _terminate(signum, frame) -> None:  # noqa: ARG001
    raise KeyboardInterrupt


def _keep_interrupts() -> None:
    """A Ctrl-C that lands where Python cannot raise it (a deallocator, a callback of a C
    library: "Exception ignored in ... KeyboardInterrupt") is delivered again to the main
    thread instead of being printed as a traceback and lost."""
    default = sys.unraisablehook

    def hook(unraisable) -> None:
        if isinstance(unraisable.exc_value, KeyboardInterrupt):
            import _thread
            import threading

            # a moment later, from another thread: the main thread raises it at a step of its
            # own, not inside this hook (where it would be ignored again)
            timer = threading.Timer(0.05, _thread.interrupt_main)
            timer.daemon = True
            timer.start()
            return
        default(unraisable)

    sys.unraisablehook = hook


def _exit_interrupted(message: str = "") -> None:
    """Exit 130, the documented code of an interrupted command.

    CPython ends a process whose main code saw a KeyboardInterrupt -- even one handled, when
    it arrived inside an import evaluated by ``PyRun_String`` -- by killing itself with
    SIGINT at exit; camsim's Ctrl-C is a handled, orderly exit 130 (docs/results.md).
    """
    if message:
        sys.stderr.write(message)
    _exit(130)


def _exit(code: int) -> None:
    """End the process: the exit handlers, the streams, then the output locks, then the process.

    The locks of the outputs are released last, a moment before the process ends (issue 45):
    a second writer can never find them free while this one is still running. The
    interpreter's own finalisation (collecting modules, about a second with h5py, matplotlib
    and Dask loaded) is skipped: every file was closed when its write ended.
    """
    import atexit
    import os

    try:
        atexit._run_exitfuncs()
    finally:
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except (OSError, ValueError):
                pass
        try:
            from camsim.io.outputs import release_claims

            release_claims()
        finally:
            os._exit(code)


if __name__ == "__main__":
    main()
