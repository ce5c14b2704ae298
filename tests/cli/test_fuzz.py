"""CLI fuzz test (issue 26): every command, its options, and hostile values.

Hypothesis draws a command, its positional arguments and a few of its options (taken from
the click command itself, so a new option is fuzzed without editing this file) with values
from a hostile alphabet: huge and negative integers, negative numbers between colons
(``normal:-1:0.1kg``), markup-like text (``[red]``), emoji codes (``:-1:``, ``:100:``),
empty strings, units, and paths to the inputs (the machine file, a result file, a directory).

The properties (the project's rules for bad input, docs/results.md and README "Exit codes"):

* no traceback ever reaches the user (the runner sees no exception but ``SystemExit``);
* the exit code is a documented one: 0, 1, 2 or 130;
* exit 2 is exactly one ``camsim: error:`` line on stderr, and nothing in the directory
  changed (no file written, none removed or modified);
* user text is echoed verbatim: no emoji appears that the input did not contain (rich
  turned ``:-1:`` into a thumbs-down and ``:100:`` into "💯").

Each example runs under a deadline: a command still running after it is interrupted as
Ctrl-C would (SIGALRM raised as KeyboardInterrupt), which must itself end cleanly (130).
The default profile is small (the default ``pytest`` must stay fast); CI (``CI=true``) runs
:data:`EXAMPLES_CI` examples.
"""

from __future__ import annotations

import os
import shutil
import signal
import tempfile
from contextlib import contextmanager
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from typer.main import get_command
from typer.testing import CliRunner

from camsim.cli import app

MACHINES = Path(__file__).resolve().parents[2] / "machines"
#: Examples per run: small by default, larger in CI (tests/conftest.py: CI=true).
EXAMPLES_DEFAULT = 25
EXAMPLES_CI = 300
EXAMPLES = EXAMPLES_CI if os.environ.get("CI", "").lower() in ("1", "true", "yes") else EXAMPLES_DEFAULT
#: Seconds an example may run before it is interrupted like Ctrl-C.
DEADLINE_S = 3
#: Options never fuzzed: they start clusters or remove the guards that keep a run small.
SKIP_OPTIONS = {"--scheduler", "--dask-local", "--yes", "-y", "--help", "-h", "--version"}
#: Every glyph rich's emoji table could put in place of a ``:code:`` in the hostile values.
EMOJI = ("👎", "💯", "👍", "❌", "🔥")

GROUP = get_command(app)
COMMANDS = sorted(GROUP.commands)
runner = CliRunner()

HOSTILE = [
    "", " ", "0", "-1", "1e300", "-1e300", "nan", "inf", "-inf", "1e-300", "abc", "[red]x[/red]", "[bold]",
    ":-1:", ":100:", "normal:-1:0.1kg", "inf:100:20", "uniform:-5:-1", "tol:1:-2", "1:2:3:4:5", "=", "==",
    "cam.speed=", "cam.speed=1e300 rpm", "element.k12.stiffness=1e300 N/m", "mass.M1.mass=-1kg",
    "mass.M2.mass=normal:-1:0.1kg", "cam.speed=60:600:0rpm", "cam.speed=600:60:10rpm", "cam.speed=1:2:1e-12rpm",
    "100 lightyear", "5 mil", "10 kHz", "-10 kHz", "0 Hz", "1e20 Hz", "\u00e9\u00e8", "a\tb", "--", "-", "@file",
    "masses/M3/acceleration", "max:nope/x", "peak_acceleration:M3=160m/s^2", "x<0N", "min_cam_contact_force<0N",
    "KEY=SPEC", "%s%d{}", "$(echo hi)", "../../etc/passwd", "*", "si", "us",
]


def _values(paths: dict[str, str]):
    """A value for any option or argument."""
    return st.one_of(
        st.sampled_from(HOSTILE),
        st.integers(min_value=-(2**70), max_value=2**70).map(str),
        st.sampled_from([str(2**64), str(2**63), str(-(2**63) - 1), "18446744073709551616", "99999999999999999999999"]),
        st.sampled_from(sorted(paths.values())),
        st.text(alphabet=st.characters(codec="utf-8", exclude_categories=("Cs", "Cc")), max_size=12),
    )


def _options(command) -> list:
    return [p for p in command.params if p.param_type_name == "option" and not set(p.opts) & SKIP_OPTIONS]


@st.composite
def invocations(draw, paths: dict[str, str]):
    """(argv, values used) for one command."""
    name = draw(st.sampled_from(COMMANDS))
    command = GROUP.commands[name]
    argv = [name]
    positional = [p for p in command.params if p.param_type_name == "argument"]
    for p in positional:
        if draw(st.booleans()) or p.required:
            argv.append(draw(st.sampled_from([paths["machine"], paths["machine"], paths["result"]]) | _values(paths)))
    options = _options(command)
    if options:
        for p in draw(st.lists(st.sampled_from(options), max_size=3)):
            opt = p.opts[0]
            if p.is_flag:
                argv.append(opt)
            else:
                argv += [opt, draw(_values(paths))]
    return argv


@contextmanager
def _deadline(seconds: int):
    """Interrupt the command like Ctrl-C after ``seconds`` (it must end with 130, cleanly)."""

    def interrupt(signum, frame):
        raise KeyboardInterrupt

    old = signal.signal(signal.SIGALRM, interrupt)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


def _snapshot(root: Path) -> dict[str, tuple[int, int]]:
    return {str(p.relative_to(root)): (p.stat().st_size, p.stat().st_mtime_ns) for p in sorted(root.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def workspace():
    """A directory with the inputs the fuzzed commands point at (made once per module)."""
    root = Path(tempfile.mkdtemp(prefix="camsim-fuzz-"))
    machine = root / "m.toml"
    shutil.copy(MACHINES / "barkan-follower.toml", machine)
    result = root / "r.h5"
    done = runner.invoke(app, ["run", str(machine), "-o", str(result), "-q", "--cycles", "1", "--warmup", "0",
                               "--sample-rate", "2 kHz"])
    assert done.exit_code == 0, done.stderr
    (root / "d").mkdir()
    yield root
    shutil.rmtree(root, ignore_errors=True)


@pytest.mark.skipif(not hasattr(signal, "SIGALRM"), reason="needs SIGALRM for the per-example deadline")
def test_cli_fuzz(workspace):
    """No traceback, documented exit codes, one-line errors that write nothing, no emoji."""
    root = workspace
    paths = {"machine": str(root / "m.toml"), "result": str(root / "r.h5"), "dir": str(root / "d"),
             "missing": str(root / "missing.toml"), "empty": ""}
    pristine = {name: (root / name).read_bytes() for name in ("m.toml", "r.h5")}

    @settings(max_examples=EXAMPLES, deadline=None, derandomize=True, database=None,
              suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
    @given(invocations(paths))
    def check(argv):
        before = _snapshot(root)
        with _deadline(DEADLINE_S):
            result = runner.invoke(app, argv)
        shown = " ".join(repr(a) for a in argv)
        assert result.exception is None or isinstance(result.exception, SystemExit), (shown, repr(result.exception))
        assert "Traceback" not in result.stderr and "Traceback" not in result.stdout, (shown, result.stderr)
        assert "internal error" not in result.stderr, (shown, result.stderr)  # the last guard of cli/app.py
        assert result.exit_code in (0, 1, 2, 130), (shown, result.exit_code, result.stderr)
        text = " ".join(argv)
        for glyph in EMOJI:
            assert glyph in text or glyph not in result.stderr, (shown, result.stderr)
        if result.exit_code == 2 and "Usage:" not in result.stderr:  # a bare group prints its help
            errors = [line for line in result.stderr.splitlines() if line.startswith("camsim: error:")]
            assert len(errors) == 1, (shown, result.stderr)
            assert _snapshot(root) == before, (shown, result.stderr)
        # whatever happened, the inputs are intact; results the command wrote are removed
        for name, data in pristine.items():
            assert (root / name).read_bytes() == data, (shown, name)
        for rel in set(_snapshot(root)) - set(before):
            (root / rel).unlink()

    check()
