"""The Typer application object and what every command shares.

Each command lives in its own module (``cmd_<name>.py``) that registers itself on
:data:`app`; the commands are thin layers over library calls. Conventions:

* human output (tables, warnings, progress) goes to stderr; ``--json`` prints only JSON
  on stdout;
* exit codes: 0 success, 1 a run that failed or a check that found a difference,
  2 bad input or usage — one line on stderr, no traceback;
* the file system's refusals (no space, a quota, a permission, a read-only file system,
  an I/O error) are the user's to fix: one line naming the file and the cause, exit 1,
  never "internal error"; that stays for real bugs;
* every command runs in an output session (:func:`camsim.io.outputs.output_session`):
  the outputs it checks stay locked until it ends.
"""

from __future__ import annotations

import json
import os
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import typer
import typer.core
from rich.console import Console

from camsim.errors import FileSystemError, InputError, SimulationError
from camsim.units import QuantityError, to_si

#: Human output: stderr, colours only on a terminal; wide enough for the tables in logs.
#: Emoji codes are off: user text such as ``normal:-1:0.1kg`` or ``inf:100:20`` is echoed
#: verbatim, never with ``:-1:`` turned into a thumbs-down (issue 26).
err_console = Console(stderr=True, highlight=False, soft_wrap=True, emoji=False)
if not err_console.is_terminal:
    err_console.width = 140

class _OneLineErrors(typer.core.TyperGroup):
    """The command group, with click's usage errors as one line (issue 26).

    Click prints a usage block, a hint and the error (three lines and a blank) for
    ``--cycles 0`` or ``-n abc``; camsim's rule for bad input is one line on stderr and
    exit 2, the same as every other input error.
    """

    def main(self, args=None, prog_name=None, complete_var=None, standalone_mode=True, **extra):  # noqa: D102
        try:  # typer >= 0.25 vendors click as typer._click; older ones use click itself
            from typer._click import exceptions as click_exceptions
        except ImportError:
            from click import exceptions as click_exceptions

        from camsim.cli.units_option import reset_error_units
        from camsim.io.outputs import output_session

        from camsim.cli.file_arguments import guard_file_arguments
        from camsim.cli.helptext import polish

        reset_error_units()
        import warnings

        polish(self)  # issue 44: examples, defaults and plain metavars in every --help
        guard_file_arguments(self, click_exceptions.UsageError)  # an empty FILE argument is bad input
        try:
            with output_session(), warnings.catch_warnings():
                # numpy's floating-point warnings are never the user's message (issue 45): a value
                # that would overflow is refused when the machine is loaded (camsim.units.LARGEST)
                warnings.simplefilter("ignore", RuntimeWarning)
                rv = super().main(args, prog_name, complete_var, standalone_mode=False, **extra)
        except getattr(click_exceptions, "NoArgsIsHelpError", ()) as exc:
            exc.show()  # a bare ``camsim``: the help, as before
            rv = 2
        except click_exceptions.UsageError as exc:
            where = exc.ctx.command_path if exc.ctx is not None else "camsim"
            message = exc.format_message() + _given(exc, sys.argv[1:] if args is None else list(args))
            err_console.print(f"camsim: error: {where}: {message} (see {where} -h)", markup=False, highlight=False)
            rv = exc.exit_code
        except click_exceptions.ClickException as exc:
            err_console.print(f"camsim: error: {exc.format_message()}", markup=False, highlight=False)
            rv = exc.exit_code
        except typer.Abort:
            err_console.print("camsim: aborted", markup=False)
            rv = 1
        except FileSystemError as exc:
            err_console.print(f"camsim: error: {exc}", markup=False, highlight=False)
            rv = 1
        except Exception as exc:  # noqa: BLE001 - the last guard: no traceback reaches the user
            if _interrupted(exc):  # Ctrl-C or SIGTERM wrapped by Python (an import's __set_name__...)
                rv = 130
            else:
                if os.environ.get("CAMSIM_TRACEBACK"):
                    raise
                if FileSystemError.applies(exc):  # the environment's, wherever it surfaced
                    err_console.print(f"camsim: error: {_environment(exc)}", markup=False, highlight=False)
                    rv = 1
                    if not standalone_mode:
                        return rv
                    sys.exit(rv)
                text = " ".join(str(exc).split()) or type(exc).__name__
                err_console.print(f"camsim: error: internal error ({type(exc).__name__}: {text}); this is a bug in "
                                  "camsim, please report it with the command line (CAMSIM_TRACEBACK=1 shows the "
                                  "traceback)", markup=False, highlight=False)
                rv = 1
        if rv == 130 and not _INTERRUPT_REPORTED[0]:  # Ctrl-C outside a command's user_errors: typer's silent 130
            err_console.print("camsim: interrupted; nothing was written", markup=False)
        _INTERRUPT_REPORTED[0] = False
        if not standalone_mode:
            return rv
        sys.exit(rv if isinstance(rv, int) else 0)


#: Set when a command said why it stops after Ctrl-C (the group says it otherwise).
_INTERRUPT_REPORTED = [False]


def _interrupted(exc: BaseException) -> bool:
    """True when ``exc`` wraps a KeyboardInterrupt (Python turns one raised inside a class's
    ``__set_name__`` -- Ctrl-C or SIGTERM while a library is imported -- into a RuntimeError)."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False


def _environment(exc: OSError) -> str:
    """One line for an OSError of the environment: the file and the cause."""
    return str(FileSystemError(exc.filename or "camsim", exc, "read or write" if not exc.filename else "use it"))


def _given(exc, args: list[str]) -> str:
    """`` (got 'abc')``: the value the user gave to the option a usage error is about."""
    param = getattr(exc, "param", None)
    opts = getattr(param, "opts", None) or []
    for i, token in enumerate(args):
        for opt in opts:
            if token == opt and i + 1 < len(args):
                return f" (got {args[i + 1]!r})"
            if token.startswith(opt + "="):
                return f" (got {token[len(opt) + 1:]!r})"
    return ""


app = typer.Typer(
    name="camsim",
    cls=_OneLineErrors,
    help=(
        "Simulate cam-driven machinery with impact and over-travel: load a TOML machine "
        "file, integrate it exactly between events, write HDF5 traces and an impact table."
    ),
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    context_settings={"help_option_names": ["-h", "--help"]},
    rich_markup_mode=None,
)


def _print_version(value: bool) -> None:
    if value:
        from camsim._version import __version__  # importlib.metadata: only when asked

        typer.echo(f"camsim {__version__}")
        raise typer.Exit()


@app.callback()
def _main(
    version: bool = typer.Option(
        False, "--version", callback=_print_version, is_eager=True, help="Print the version and exit."
    ),
) -> None:
    """camsim: exact simulation of cam-follower systems with impact."""


def warn(message: str) -> None:
    """Print ``camsim: warning: message`` on stderr (a message already in the user's units)."""
    err_console.print(f"camsim: warning: {message}", markup=False, highlight=False)


def warn_notes(machine) -> None:
    """The warnings of how a machine file was read (``Machine.notes``: bare numbers taken as SI)."""
    for note in getattr(machine, "notes", ()):
        warn(note)


def fail(message: str, code: int = 2) -> typer.Exit:
    """Print ``camsim: error: message`` on stderr and return the Exit to raise."""
    err_console.print(f"camsim: error: {message}", markup=False, highlight=False)
    if code == 130:
        _INTERRUPT_REPORTED[0] = True
    return typer.Exit(code=code)


@contextmanager
def user_errors() -> Iterator[None]:
    """Turn camsim errors into one line on stderr and the documented exit code."""
    from camsim.cli.units_option import error_text  # values quoted in the command's display units

    try:
        yield
    except InputError as exc:
        raise fail(error_text(str(exc)), 2) from None
    except SimulationError as exc:
        raise fail(error_text(str(exc)), 1) from None
    except FileSystemError as exc:
        raise fail(str(exc), 1) from None
    except OSError as exc:
        if not FileSystemError.applies(exc):
            raise
        raise fail(_environment(exc), 1) from None
    except KeyboardInterrupt:
        err_console.print("camsim: interrupted; nothing was written under the output name")
        _INTERRUPT_REPORTED[0] = True
        raise typer.Exit(code=130) from None


def parse_sample_rate(text: str | None) -> float | None:
    if text is None:
        return None
    try:
        value = to_si(text, "frequency")
    except QuantityError as exc:
        raise fail(f"--sample-rate: {exc}") from None
    if value <= 0:
        raise fail("--sample-rate: must be positive")
    return value


def print_json(payload: Any) -> None:
    """Print ``payload`` as JSON on stdout (the only thing a ``--json`` command prints there).

    JSON has no NaN or infinity: non-finite numbers (a quantity that does not apply, the
    unbounded Johnson force of a rigid stop) are written as null.
    """
    sys.stdout.write(json.dumps(_finite(payload), indent=2, allow_nan=False, default=_jsonable) + "\n")


def _finite(value: Any) -> Any:
    import math

    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _finite(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_finite(v) for v in value]
    return value


def _jsonable(value: Any) -> Any:
    import numpy as np

    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")
