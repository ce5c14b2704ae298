"""The conformance suite (issue 35): generated from what each command declares it reads and writes.

Every command declares its inputs and outputs next to its definition
(:mod:`camsim.cli.contracts`). From those declarations this module builds, for

* every output × {onto an input, over a file of another kind, over a file camsim did not
  write, in a read-only folder, onto a full disk, beside a concurrent writer, SIGKILL,
  SIGINT and SIGTERM at a random moment}, every output locked from the command's checks
  (issue 45), and
* every input × {truncated, empty, foreign HDF5, a CSV, attributes only, a missing dataset,
  flipped metadata bytes, a non-finite trace, a reversed time base},

the documented outcome (the table in :mod:`camsim.cli.contracts`, docs/results.md "Output
policy", "Locks", "Environment errors"). A command, or a file parameter of one, that
declares nothing fails :func:`test_every_command_declares_what_it_reads_and_writes`.

The default ``pytest`` runs a small selection (every refusal of every command's main
output, every damaged input, a full disk and the signals for ``run`` and ``sweep``:
about 20 s); with ``CI=true`` (``.ci/run``) every case runs, a signal at one seeded moment
per case (three with ``CAMSIM_FULL=1``). A full disk is a small tmpfs
when the tests run as root and may mount one, else an ENOSPC injected at the one write
every byte goes through (:func:`camsim.io.atomic.raw_write`). A read-only folder is a
read-only tmpfs as root, a mode-0555 folder otherwise.
"""

from __future__ import annotations

import fcntl
import os
import random
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
import pytest
from typer.testing import CliRunner

import camsim.cli  # noqa: F401 - registers every command and its contract

sys.path.insert(0, str(Path(__file__).resolve().parent))
from filesystem import MACHINE, fill, inject_enospc, mount_tmpfs, umount  # noqa: E402
from interrupts import at_a_terminal  # noqa: E402
from camsim.cli import app
from camsim.cli.contracts import CONTRACTS, PROTECTED

ROOT = Path(__file__).resolve().parents[2]
CI = os.environ.get("CI", "").lower() in ("1", "true", "yes") or os.environ.get("CAMSIM_SLOW") == "1"
runner = CliRunner()

OUT_CASES = ("input", "other_kind", "foreign", "readonly", "locked", "full_disk", "sigkill", "sigint", "sigterm")
IN_CASES = ("truncated", "empty", "foreign_hdf5", "csv", "attributes_only", "missing_dataset", "flipped", "nonfinite",
            "reversed_time")
#: Damage only an HDF5 result can have (issue 45: readers that distrust).
RESULT_CASES = ("attributes_only", "missing_dataset", "flipped", "nonfinite", "reversed_time")
#: Cases that refuse before anything is computed (fast, in-process).
REFUSALS = ("input", "other_kind", "foreign", "readonly", "locked")
#: (command, option, case) of the default run beyond the refusals of each main output.
SMALL = {("run", "-o", "full_disk"), ("export", "-o", "full_disk"), ("sweep", "-o", "full_disk"),
         ("run", "-o", "sigkill"), ("sweep", "-o", "sigint")}


# ------------------------------------------------------------------------------ fixtures
@pytest.fixture(scope="module")
def files(tmp_path_factory) -> dict[str, Path]:
    """The example inputs: machine files, a run result, a measured CSV, a parts file..."""
    d = tmp_path_factory.mktemp("inputs")
    out = {"machine": d / "machine.toml", "geometry": d / "geometry.toml", "parts": d / "parts.toml",
           "config": d / "study.toml", "measured": d / "measured.csv", "deflection": d / "deflection.csv"}
    out["machine"].write_text(MACHINE)
    shutil.copy(ROOT / "machines" / "cdtm-geometry.toml", out["geometry"])
    shutil.copy(ROOT / "machines" / "cdtm-parts.toml", out["parts"])
    out["config"].write_text(f'[study]\nmachine = "{out["machine"]}"\ndist = ["element.K.preload=normal:40N:1N"]\n'
                             "samples = 2\nworkers = 1\n")
    # measured: the closed-form cam contact force of MACHINE, Fc = m s'' + P + k s (tests/fit/machines.py)
    t = np.linspace(0.0, 0.5, 51)
    w, h = 4 * np.pi, 0.01
    force = 2.0 * (h / 2) * w**2 * np.cos(w * t) + 40.0 + 5000.0 * (h / 2) * (1 - np.cos(w * t))
    out["measured"].write_text("time [s],cam_contact/force [N]\n" + "".join(f"{a!r},{b!r}\n" for a, b in zip(t, force)))
    out["deflection"].write_text("deflection [in],force [lbf]\n0.001,10\n0.002,27\n0.003,48\n0.004,71\n")
    run = d / "run.h5"
    r = runner.invoke(app, ["run", str(out["machine"]), "-o", str(run), "-q"])
    assert r.exit_code == 0, r.output
    out["run"] = run
    return out


def _lock_holder(path: Path) -> tuple[int, int]:
    """Hold the lock of output ``path`` as another writer would (returns fd, the id written)."""
    from camsim.io.locks import lock_path_for

    fd = os.open(lock_path_for(path), os.O_RDWR | os.O_CREAT, 0o644)
    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    pid = os.getppid()  # a live process that is not this one
    os.write(fd, f"{pid}\n".encode())
    return fd, pid


# ------------------------------------------------------------------------------ the cases
def _outputs():
    for name, c in sorted(CONTRACTS.items()):
        for k, w in enumerate(c.writes):
            yield name, c, k, w


def _out_params():
    params = []
    for name, c, k, w in _outputs():
        main = k == 0
        for case in OUT_CASES:
            if case == "foreign" and w.format not in PROTECTED:
                continue  # documented: replaced (camsim never holds a user's only copy there)
            if case == "input" and (w.beside or not c.reads):
                continue  # a companion's name is chosen away from the inputs (companion_path)
            small = (main and case in REFUSALS and not c.slow) or (name, w.option, case) in SMALL and not w.beside
            marks = () if small else (pytest.mark.slow,)
            label = f"{name}:{w.option}{'(' + w.beside + ')' if w.beside else ''}:{case}"
            params.append(pytest.param(name, k, case, id=label, marks=marks))
    return params


def _in_params():
    params = []
    for name, c in sorted(CONTRACTS.items()):
        for k, r in enumerate(c.reads):
            for case in IN_CASES:
                if case in RESULT_CASES and r.kind != "result":
                    continue  # HDF5 layouts: only results have them
                marks = (pytest.mark.slow,) if c.slow else ()
                params.append(pytest.param(name, k, case, id=f"{name}:{r.param}{'' if k == 0 or r.param != c.reads[0].param else '#' + str(k)}:{case}", marks=marks))
    return params


def _paths(c, tmp: Path, files: dict[str, Path]) -> dict[str, Path]:
    """Where each output of ``c`` goes in ``tmp`` (by option; companions by option + beside)."""
    out = {}
    for w in c.writes:
        if w.beside:
            continue
        if w.directory:
            out[w.option] = tmp / "figures"
        else:
            out[w.option] = tmp / f"out{w.option.strip('-').replace('-', '_')}{w.suffix}"
    return out


def _target(c, w, paths: dict[str, Path], inputs: dict[str, Path]) -> Path:
    """The one file of output ``w`` the case looks at."""
    if w.beside:
        base = paths[w.beside.split(":")[0]]
        suffix = w.beside.split(":", 1)[1]
        return base.with_name(base.name + suffix[1:]) if suffix.startswith("+") else base.with_suffix(suffix)
    if w.directory:
        stem = next(v for key, v in inputs.items() if key != "__files__").stem
        return paths[w.option] / w.directory.format(stem=stem, fmt=w.format)
    return paths[w.option]


def _args(c, paths: dict[str, Path], inputs: dict[str, Path], keep: str | None, example=None) -> list[str]:
    """The example with its placeholders filled; optional outputs other than ``keep`` left out."""
    optional = set() if keep == "*" else {w.option for w in c.writes if w.optional and w.option != keep}
    tokens = list(example or c.example)
    out: list[str] = []
    i = 0
    while i < len(tokens):
        tok = tokens[i]
        if i + 1 < len(tokens) and tokens[i + 1].startswith("{out:") and tokens[i + 1][5:-1] in optional:
            i += 2
            continue
        if tok.startswith("{out:"):
            out.append(str(paths[tok[5:-1]]))
        elif tok.startswith("{in:"):
            out.append(str(inputs[tok[4:-1]]))
        elif tok.startswith("{") and tok.endswith("}"):
            out.append(str(inputs.get(tok[1:-1]) or inputs["__files__"][tok[1:-1]]))
        else:
            out.append(tok)
        i += 1
    return out


def _inputs(c, tmp: Path, files: dict[str, Path]) -> dict[str, Path]:
    """Copies of the example inputs of ``c`` in ``tmp`` (so an overwrite would show)."""
    out: dict = {"__files__": files}
    for r in c.reads:
        if r.param in out or r.example:
            continue
        fixture = r.fixture or {"result": "run"}.get(r.kind, r.kind)
        src = files[fixture]
        dst = tmp / f"in_{r.param}{src.suffix}"
        shutil.copy(src, dst)
        out[r.param] = dst
    return out


def _invoke(args: list[str]):
    return runner.invoke(app, args)


def _one_line_error(result, code: int) -> str:
    text = result.stderr
    assert result.exit_code == code, (result.exit_code, text, result.stdout)
    assert "Traceback" not in text and "internal error" not in text, text
    lines = [line for line in text.splitlines() if line.startswith("camsim: error:")]
    assert len(lines) == 1, text
    return lines[0]


def _no_temps(directory: Path) -> None:
    left = [p.name for p in directory.rglob("*") if p.name.endswith(".tmp")]
    assert not left, left


# ------------------------------------------------------------------------------ declarations
def _commands():
    import typer.main

    def walk(group, prefix=""):
        for name, cmd in sorted(group.commands.items()):
            path = f"{prefix}{name}"
            yield path, cmd
            if hasattr(cmd, "commands"):
                yield from walk(cmd, path + " ")

    yield from walk(typer.main.get_command(app))


def test_every_command_declares_what_it_reads_and_writes():
    """A new command (or a new file option) fails here until it declares its files."""
    import typing

    missing, undeclared = [], []
    for path, cmd in _commands():
        contract = CONTRACTS.get(path)
        if contract is None:
            missing.append(path)
            continue
        declared = {r.param for r in contract.reads} | {w.param for w in contract.writes if w.param}
        hints = typing.get_type_hints(cmd.callback) if cmd.callback is not None else {}
        for param, hint in hints.items():
            if "Path" in str(hint) and param not in declared:  # Path, Path | None, list[Path]
                undeclared.append(f"{path}: {param}")
        assert contract.example or not (contract.reads or contract.writes), f"{path}: no example invocation"
    assert not missing, f"commands without a declaration in camsim.cli.contracts: {missing}"
    assert not undeclared, f"file parameters not declared as read or written: {undeclared}"


@pytest.mark.slow
def test_the_examples_run(files, tmp_path):
    """Each fast example does what it declares: exit 0 and every non-optional output written
    (the cases below start from them)."""
    for name, c in sorted(CONTRACTS.items()):
        if c.slow or not c.example:
            continue
        d = tmp_path / name.replace(" ", "_")
        d.mkdir()
        inputs = _inputs(c, d, files)
        paths = _paths(c, d, files)
        r = _invoke(_args(c, paths, inputs, None))
        assert r.exit_code == 0, (name, r.stderr)
        for w in c.writes:
            if not w.optional:
                assert _target(c, w, paths, inputs).exists() != w.transient, (name, w.option, w.beside)
        _no_temps(d)
        assert not list(d.rglob(".*.lock")) and not list(d.rglob("*.journal")), name


def _claims_params():
    fast = {"run", "sweep", "export", "optimize"}
    return [pytest.param(name, id=name, marks=() if name in fast else (pytest.mark.slow,))
            for name, c in sorted(CONTRACTS.items()) if c.writes and c.example and not c.slow]


@pytest.mark.parametrize("name", _claims_params())
def test_every_output_is_locked_from_the_check(name, files, tmp_path, monkeypatch):
    """Issue 45: every file a command writes (companions, journals, figures included) is locked
    when the command checks its outputs, before anything is computed, not when it is written:
    each write finds its output already claimed by the command's checks (a journal or a row
    store's view: its job's output). Before, an output that did not exist yet was never
    claimed: two `optimize -o o.toml` at once both wrote o.toml."""
    import camsim.io.atomic as atomic
    import camsim.io.outputs as outputs

    c = CONTRACTS[name]
    inputs = _inputs(c, tmp_path, files)
    paths = _paths(c, tmp_path, files)
    late: list[str] = []
    real = atomic.Target.__init__

    def target_init(self, final, *args, **kwargs):
        key = os.path.realpath(final)
        owners = {key, key.removesuffix(".journal")}
        if not owners & set(outputs._CLAIMS):
            late.append(str(final))
        real(self, final, *args, **kwargs)

    monkeypatch.setattr(atomic.Target, "__init__", target_init)
    r = _invoke(_args(c, paths, inputs, "*"))
    assert r.exit_code == 0, r.stderr
    assert not late, f"{name}: written without a claim from the command's checks: {late}"


# ------------------------------------------------------------------------------ outputs
@pytest.mark.parametrize("name,k,case", _out_params())
def test_output(name, k, case, files, tmp_path, monkeypatch):
    c = CONTRACTS[name]
    w = c.writes[k]
    keep = w.beside.split(":")[0] if w.beside else w.option
    inputs = _inputs(c, tmp_path, files)
    paths = _paths(c, tmp_path, files)
    target = _target(c, w, paths, inputs)
    run = {"input": _case_input, "other_kind": _case_other_kind, "foreign": _case_foreign, "readonly": _case_readonly,
           "locked": _case_locked, "full_disk": _case_full_disk, "sigkill": _case_signal, "sigint": _case_signal,
           "sigterm": _case_signal}[case]
    run(c, w, keep, inputs, paths, target, tmp_path, monkeypatch=monkeypatch, case=case)


def _case_input(c, w, keep, inputs, paths, target, tmp, **_):
    """Output onto an input: exit 2, the input untouched."""
    victim = next(v for key, v in inputs.items() if key != "__files__")
    before = victim.read_bytes()
    paths[w.option] = victim
    line = _one_line_error(_invoke(_args(c, paths, inputs, keep)), 2)
    assert str(victim) in line or victim.name in line, line
    assert victim.read_bytes() == before


def _other_kind(fmt: str, path: Path) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    if fmt == "hdf5":
        path.write_text('schema = 1\n[machine]\nname = "a machine file, not a result"\n')
    else:
        with h5py.File(path, "w") as f:
            f["x"] = np.arange(3.0)


def _case_other_kind(c, w, keep, inputs, paths, target, tmp, **_):
    """Over a file of another kind (by its bytes): exit 2, untouched, --force or not."""
    _other_kind(w.format, target)
    before = target.read_bytes()
    for force in ([False, True] if c.force else [False]):
        args = _args(c, paths, inputs, keep) + (["--force"] if force else [])
        _one_line_error(_invoke(args), 2)
        assert target.read_bytes() == before


def _case_foreign(c, w, keep, inputs, paths, target, tmp, **_):
    """Over a file of the same kind camsim did not write (HDF5, TOML, HTML): exit 2 without --force."""
    target.parent.mkdir(parents=True, exist_ok=True)
    if w.format == "hdf5":
        with h5py.File(target, "w") as f:
            f["data"] = np.arange(4.0)
    elif w.format == "toml":
        target.write_text('schema = 1\n[machine]\nname = "written by hand"\n')
    else:
        target.write_text("<!DOCTYPE html><html><body>my notes</body></html>\n")
    before = target.read_bytes()
    line = _one_line_error(_invoke(_args(c, paths, inputs, keep)), 2)
    assert "--force" in line, line
    assert target.read_bytes() == before


def _case_readonly(c, w, keep, inputs, paths, target, tmp, **_):
    """In a read-only folder: exit 2 before anything is computed, nothing written."""
    ro = tmp / "ro"
    mounted = mount_tmpfs(ro, "ro,size=64k")
    if not mounted:
        if os.geteuid() == 0:
            pytest.skip("running as root without permission to mount a read-only tmpfs")
        ro.mkdir()
    _move_outputs(c, w, paths, ro)
    target = _target(c, w, paths, inputs)
    try:
        if not mounted:
            ro.chmod(0o555)
        _one_line_error(_invoke(_args(c, paths, inputs, keep)), 2)
        assert not target.exists()
    finally:
        if mounted:
            umount(ro)
        else:
            ro.chmod(0o755)


def _move_outputs(c, w, paths, folder: Path) -> None:
    """Put the output under test (with its main output, for a companion) into ``folder``."""
    option = w.beside.split(":")[0] if w.beside else w.option
    paths[option] = folder / paths[option].name


def _case_locked(c, w, keep, inputs, paths, target, tmp, **_):
    """Beside a concurrent writer (its lock held): exit 2 naming its process id, nothing written."""
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, pid = _lock_holder(target)
    try:
        line = _one_line_error(_invoke(_args(c, paths, inputs, keep)), 2)
        assert f"PID {pid}" in line, line
        assert not target.exists()
    finally:
        os.close(fd)


def _case_full_disk(c, w, keep, inputs, paths, target, tmp, monkeypatch, **_):
    """Onto a full disk: exit 1, one line naming a file there and the cause, nothing under the
    output's name, no temporary file; never a signal, never "internal error"."""
    full = tmp / "full"
    if mount_tmpfs(full, "size=256k"):
        try:
            fill(full)
            _move_outputs(c, w, paths, full)
            target = _target(c, w, paths, inputs)
            line = _one_line_error(_invoke(_args(c, paths, inputs, keep)), 1)
            assert str(full) in line and "no space left" in line, line
            assert not target.exists()
            _no_temps(full)
        finally:
            umount(full)
        return
    inject_enospc(monkeypatch)
    line = _one_line_error(_invoke(_args(c, paths, inputs, keep)), 1)
    assert str(tmp) in line and "no space left" in line, line
    assert not target.exists()
    _no_temps(tmp)


def _case_signal(c, w, keep, inputs, paths, target, tmp, case, **_):
    """SIGKILL, SIGINT or SIGTERM at a random moment: the output absent or complete; SIGINT and SIGTERM
    exit 130 (or 0 when the command finished first) leaving no temporary file; after SIGKILL the same
    command (with --resume when it left a journal) completes and cleans up."""
    args = _args(c, paths, inputs, keep)
    rng = random.Random(f"{c.command}{w.option}{case}")
    env = {**os.environ, "PYTHONWARNINGS": "ignore"}
    trials = 3 if os.environ.get("CAMSIM_FULL") == "1" else 1  # kill moments (seeded): 3 before a release
    for trial in range(trials):
        proc = subprocess.Popen([sys.executable, "-m", "camsim", *args], cwd=tmp, env=env, stdout=subprocess.PIPE,
                                stderr=subprocess.PIPE, preexec_fn=at_a_terminal)
        time.sleep(rng.uniform(0.3, 2.5))
        proc.send_signal({"sigkill": signal.SIGKILL, "sigint": signal.SIGINT, "sigterm": signal.SIGTERM}[case])
        out, err = proc.communicate(timeout=120)
        text = err.decode(errors="replace")
        if case in ("sigint", "sigterm"):  # issue 45: SIGTERM takes Ctrl-C's orderly way out
            assert proc.returncode in (0, 130, 1), (proc.returncode, text)
            assert "Traceback" not in text and "internal error" not in text, text
            _no_temps(tmp)
        else:
            assert proc.returncode in (0, -signal.SIGKILL), proc.returncode
        _valid_or_absent(w, target)
        again = args + (["--resume"] if list(tmp.rglob("*.journal")) else [])
        r = subprocess.run([sys.executable, "-m", "camsim", *again], cwd=tmp, env=env, capture_output=True, timeout=300)
        assert r.returncode == 0, r.stderr.decode(errors="replace")
        _valid_or_absent(w, target, present=not w.transient and (not w.optional or keep == w.option))
        _no_temps(tmp)
        assert not list(tmp.rglob(".*.lock")), list(tmp.rglob(".*.lock"))


def _valid_or_absent(w, target: Path, present: bool = False) -> None:
    if not target.exists():
        assert not present, target
        return
    if w.format == "hdf5":
        with h5py.File(target, "r") as f:  # a complete HDF5 file
            assert "camsim_version" in f.attrs
    else:
        assert target.stat().st_size > 0


# ------------------------------------------------------------------------------ inputs
def _damage(case: str, src: Path, dst: Path, kind: str) -> str | None:
    """Write a damaged ``src`` to ``dst``; returns the dataset the message must name (or None)."""
    data = src.read_bytes()
    if case == "truncated":
        if kind == "csv":  # cut inside the first field of a row: a row with one cell
            cut = data.index(b"\n", len(data) // 2) + 2
        else:
            cut = len(data) // 2
        dst.write_bytes(data[:cut])
    elif case == "empty":
        dst.write_bytes(b"")
    elif case == "foreign_hdf5":
        with h5py.File(dst, "w") as f:
            f["time"] = np.arange(5.0)
            f.attrs["title"] = "somebody else's data"
    elif case == "csv":
        dst.write_text("a,b\n1,2\n3,4\n")
    elif case == "attributes_only":
        with h5py.File(src, "r") as s, h5py.File(dst, "w") as f:
            for key, value in s.attrs.items():
                f.attrs[key] = value
        return "events"
    elif case == "missing_dataset":
        shutil.copy(src, dst)
        with h5py.File(dst, "r+") as f:
            mass = next(iter(f["masses"]))
            del f[f"masses/{mass}/velocity"]
        return f"masses/{mass}/velocity"
    elif case == "flipped":  # 16 bytes of the event table's object header (its checksum fails)
        with h5py.File(src, "r") as f:
            addr = h5py.h5o.get_info(f["events"].id).addr
        damaged = bytearray(data)
        for i in range(addr + 16, addr + 32):
            damaged[i] ^= 0xFF
        dst.write_bytes(bytes(damaged))
        return "events"
    elif case == "nonfinite":  # NaN in a trace the layout holds finite
        shutil.copy(src, dst)
        with h5py.File(dst, "r+") as f:
            mass = next(iter(f["masses"]))
            f[f"masses/{mass}/velocity"][1] = np.nan
        return f"masses/{mass}/velocity"
    elif case == "reversed_time":
        shutil.copy(src, dst)
        with h5py.File(dst, "r+") as f:
            f["time"][...] = f["time"][()][::-1]
        return "time"
    return None


@pytest.mark.parametrize("name,k,case", _in_params())
def test_input(name, k, case, files, tmp_path):
    """A damaged input: exit 2, one line naming the file (and the dataset), nothing written."""
    c = CONTRACTS[name]
    r = c.reads[k]
    inputs = _inputs(c, tmp_path, files)
    paths = _paths(c, tmp_path, files)
    fixture = r.fixture or {"result": "run"}.get(r.kind, r.kind)
    src = files[fixture]
    damaged = tmp_path / f"damaged{src.suffix}"
    where = _damage(case, src, damaged, r.kind)
    inputs[r.param] = damaged
    args = _args(c, paths, inputs, None, example=r.example or None)
    if r.example:
        args = [str(damaged) if a == str(inputs.get(r.param)) else a for a in args]
    line = _one_line_error(_invoke(args), 2)
    assert damaged.name in line, line
    if where is not None:
        assert where in line, line
    written = [p for p in paths.values() if p.exists()]
    assert not written, written
