"""The Typer application object and what every command shares.

Each command lives in its own module (``cmd_<name>.py``) that registers itself on
:data:`app`; the commands are thin layers over library calls. Conventions:

* human output (tables, warnings, progress) goes to stderr; ``--json`` prints only JSON
  on stdout;
* exit codes: 0 success, 1 a run that failed or a check that found a difference,
  2 bad input or usage — one line on stderr, no traceback.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import typer
from rich.console import Console

from camsim._version import __version__
from camsim.errors import InputError, SimulationError
from camsim.units import QuantityError, to_si

#: Human output: stderr, colours only on a terminal; wide enough for the tables in logs.
err_console = Console(stderr=True, highlight=False, soft_wrap=True, emoji=False)  # ":100:" in a range is not 💯
if not err_console.is_terminal:
    err_console.width = 140

app = typer.Typer(
    name="camsim",
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
        typer.echo(f"camsim {__version__}")
        raise typer.Exit()


@app.callback()
def _main(
    version: bool = typer.Option(
        False, "--version", callback=_print_version, is_eager=True, help="Print the version and exit."
    ),
) -> None:
    """camsim: exact simulation of cam-follower systems with impact."""


def fail(message: str, code: int = 2) -> typer.Exit:
    """Print ``camsim: error: message`` on stderr and return the Exit to raise."""
    err_console.print(f"camsim: error: {message}", markup=False, highlight=False)
    return typer.Exit(code=code)


@contextmanager
def user_errors() -> Iterator[None]:
    """Turn camsim errors into one line on stderr and the documented exit code."""
    try:
        yield
    except InputError as exc:
        raise fail(str(exc), 2) from None
    except SimulationError as exc:
        raise fail(str(exc), 1) from None
    except KeyboardInterrupt:
        err_console.print("camsim: interrupted; nothing was written under the output name")
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
