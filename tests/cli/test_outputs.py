"""Issue 26: the output policy (camsim/io/outputs.py) and the journal rule, as the user meets them.

Each test reproduces one case of issue 26's "Why" (data loss, crashes, garbled echo, usage
blocks) and checks the documented behaviour instead (docs/results.md "Output policy"): exit
2 with one line naming what to do, and the user's file byte for byte unchanged. The
references are the input files' own bytes (read before the command) and the documented
exit codes; no number of camsim is checked here.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import h5py
import pytest
from typer.testing import CliRunner

from camsim.cli import app

MACHINES = Path(__file__).resolve().parents[2] / "machines"
BARKAN = MACHINES / "barkan-follower.toml"
FAST = ["--cycles", "1", "--warmup", "0", "--sample-rate", "2 kHz"]
runner = CliRunner()


@pytest.fixture
def machine(tmp_path) -> Path:
    """A copy of the Barkan follower machine in tmp_path (the input the commands must not touch)."""
    path = tmp_path / "barkan.toml"
    shutil.copy(BARKAN, path)
    return path


def _one_line_error(result) -> str:
    """The single stderr line of a refused command (no traceback, no usage block)."""
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith("camsim: error: "), result.stderr
    assert "Traceback" not in result.stderr
    return lines[0]


@pytest.mark.parametrize(
    "command",
    [
        ["sweep", "--values", "cam.speed=420rpm,450rpm", "--workers", "1"],
        ["study", "--dist", "cam.speed=uniform:400:440rpm", "-n", "2", "--workers", "1"],
        ["run"],
        ["compare"],
    ],
)
def test_output_over_the_machine_file_is_refused(machine, command):
    """`-o <machine.toml>` (issue 26: study/sweep overwrote the machine file with HDF5 bytes).

    Reference: the machine file's bytes before the command; exit 2 (bad input)."""
    before = machine.read_bytes()
    result = runner.invoke(app, [command[0], str(machine), *command[1:], "-o", str(machine), *FAST])
    assert result.exit_code == 2, result.stderr
    line = _one_line_error(result)
    assert str(machine) in line
    assert machine.read_bytes() == before
    assert sorted(p.name for p in machine.parent.iterdir()) == ["barkan.toml"]


@pytest.mark.parametrize("command", [["run"], ["sweep", "--values", "cam.speed=420rpm,450rpm", "--workers", "1"],
                                     ["study", "--dist", "cam.speed=uniform:400:440rpm", "-n", "2", "--workers", "1"]])
def test_unknown_or_wrong_suffix_is_exit_2_naming_the_formats(machine, command):
    """`run -o x.csv` wrote HDF5 under a .csv name; `sweep/study -o out.csv` wrote the HDF5
    file and then the CSV over it. The format comes from the suffix: .csv is not what these
    commands write (they write .h5/.hdf5, the CSV beside it). Reference: docs/results.md."""
    out = machine.parent / "out.csv"
    result = runner.invoke(app, [command[0], str(machine), *command[1:], "-o", str(out), *FAST])
    assert result.exit_code == 2, result.stderr
    line = _one_line_error(result)
    assert ".h5" in line and "'.csv'" in line
    assert not out.exists()


def test_companion_csv_has_its_own_name(machine):
    """The CSV beside a sweep's HDF5 file never takes the HDF5 file's name ("wrote out.csv and out.csv")."""
    out = machine.parent / "s.h5"
    result = runner.invoke(app, ["sweep", str(machine), "--values", "cam.speed=420rpm", "--workers", "1", "-o", str(out), *FAST])
    assert result.exit_code == 0, result.stderr
    assert "wrote " + str(out) + " and " + str(machine.parent / "s.csv") in result.stderr
    assert h5py.is_hdf5(out)
    assert not h5py.is_hdf5(machine.parent / "s.csv")


def test_result_of_another_command_needs_force(machine):
    """A sweep does not replace a run result without --force (docs/results.md)."""
    out = machine.parent / "r.h5"
    assert runner.invoke(app, ["run", str(machine), "-o", str(out), "-q", *FAST]).exit_code == 0
    before = out.read_bytes()
    result = runner.invoke(app, ["sweep", str(machine), "--values", "cam.speed=420rpm", "--workers", "1", "-o", str(out), *FAST])
    assert result.exit_code == 2
    assert "--force" in _one_line_error(result)
    assert out.read_bytes() == before
    forced = runner.invoke(app, ["sweep", str(machine), "--values", "cam.speed=420rpm", "--workers", "1", "-o", str(out), "--force", *FAST])
    assert forced.exit_code == 0, forced.stderr
    with h5py.File(out) as f:
        assert f.attrs["file_kind"] == "sweep"


def test_rerun_of_the_same_result_needs_no_force(machine):
    """Running the same command again replaces its own result (no --force needed)."""
    out = machine.parent / "r.h5"
    for _ in range(2):
        result = runner.invoke(app, ["run", str(machine), "-o", str(out), "-q", *FAST])
        assert result.exit_code == 0, result.stderr


def test_csv_companion_never_over_a_toml(machine):
    """`sweep -o barkan.h5` would put its CSV companion at barkan.csv; a TOML there is refused."""
    other = machine.parent / "b.csv"
    other.write_text('name = "a TOML file named .csv"\n')
    before = other.read_bytes()
    result = runner.invoke(app, ["sweep", str(machine), "--values", "cam.speed=420rpm", "--workers", "1", "-o", str(machine.parent / "b.h5"), *FAST])
    assert result.exit_code == 2
    assert "TOML" in _one_line_error(result)
    assert other.read_bytes() == before


def test_interrupted_sweep_journal_is_not_discarded(machine):
    """Issue 26: after a killed sweep, rerunning without --resume truncated the journal and
    started from row 0. Now: exit 2 naming --resume and --fresh; the journal is unchanged;
    --resume continues from it; --fresh starts again. Reference: the journal's bytes."""
    from camsim.analyses.sweep.runner import run_sweep
    from camsim.io.rowstore import journal_path_for

    out = machine.parent / "s.h5"
    calls = []

    def stop_after_first(done, total):
        calls.append(done)
        if done == 1:
            raise KeyboardInterrupt

    sweep = run_sweep(machine, values=["cam.speed=420rpm,450rpm,480rpm"], workers=1, cycles=1, warmup_cycles=0,
                      sample_rate=2000.0, output=out, progress=stop_after_first)
    assert sweep.interrupted
    journal = journal_path_for(out)
    before = journal.read_bytes()
    args = ["sweep", str(machine), "--values", "cam.speed=420rpm,450rpm,480rpm", "--workers", "1", "-o", str(out), *FAST]
    result = runner.invoke(app, args)
    assert result.exit_code == 2
    line = _one_line_error(result)
    assert "--resume" in line and "--fresh" in line
    assert journal.read_bytes() == before
    resumed = runner.invoke(app, [*args, "--resume"])
    assert resumed.exit_code == 0, resumed.stderr
    assert "resumed: 1 of 3" in resumed.stderr
    assert not journal.exists()


def test_fresh_discards_the_journal(machine):
    """--fresh is the explicit way to start again (the journal goes, the sweep runs in full)."""
    from camsim.io.rowstore import journal_path_for

    out = machine.parent / "s.h5"
    journal_path_for(out).write_text("left by a killed sweep\n")
    result = runner.invoke(app, ["sweep", str(machine), "--values", "cam.speed=420rpm", "--workers", "1", "-o", str(out), "--fresh", *FAST])
    assert result.exit_code == 0, result.stderr
    assert not journal_path_for(out).exists()


def test_study_seed_of_2_to_the_64_is_refused_up_front(machine):
    """Issue 26: --seed 18446744073709551616 ran every sample and then crashed writing the
    seed attribute (a half file). Now exit 2 before any run; nothing written."""
    out = machine.parent / "st.h5"
    result = runner.invoke(app, ["study", str(machine), "--dist", "cam.speed=uniform:400:440rpm", "-n", "2",
                                 "--seed", str(2**64), "-o", str(out), "--workers", "1", *FAST])
    assert result.exit_code == 2, result.stderr
    line = _one_line_error(result)
    assert str(2**64) in line
    assert sorted(p.name for p in machine.parent.iterdir()) == ["barkan.toml"]


def test_study_sensitivity_with_one_sample_is_refused(machine):
    """Issue 26: `study -n 1 --sensitivity` ended in a scipy traceback. Now exit 2 with the reason."""
    result = runner.invoke(app, ["study", str(machine), "--dist", "cam.speed=uniform:400:440rpm", "-n", "1",
                                 "--sensitivity", "-o", str(machine.parent / "st.h5"), "--workers", "1", *FAST])
    assert result.exit_code == 2, result.stderr
    assert "--sensitivity" in _one_line_error(result)
    assert sorted(p.name for p in machine.parent.iterdir()) == ["barkan.toml"]


@pytest.mark.parametrize("spec", ["normal:-1:0.1kg", "normal:1:100:kg", "[red]x[/red]"])
def test_errors_echo_the_input_verbatim(machine, spec):
    """Issue 26: `--dist mass.M2.mass=normal:-1:0.1kg` was echoed with a thumbs-down emoji in
    place of `:-1:`. Reference: the text the user typed, which must appear unchanged."""
    text = f"mass.M1.mass={spec}"
    result = runner.invoke(app, ["study", str(machine), "--dist", text, "-n", "2", "--workers", "1", *FAST])
    assert result.exit_code == 2, result.stderr
    line = _one_line_error(result)
    assert spec in line


@pytest.mark.parametrize("args", [["run", "{m}", "--cycles", "0"], ["study", "{m}", "-n", "abc"], ["run"], ["sweep", "{m}", "--bogus"]])
def test_usage_errors_are_one_line(machine, args):
    """Issue 26: click printed a 3-line usage block for `--cycles 0`, `-n abc`. Now one line, exit 2."""
    result = runner.invoke(app, [a.format(m=machine) for a in args])
    assert result.exit_code == 2
    line = _one_line_error(result)
    assert args[0] in line


def test_compare_with_one_result_file_names_what_it_takes(machine):
    """Issue 26: `camsim compare one.h5` said "not UTF-8 text". Now it names what compare takes."""
    out = machine.parent / "r.h5"
    assert runner.invoke(app, ["run", str(machine), "-o", str(out), "-q", *FAST]).exit_code == 0
    result = runner.invoke(app, ["compare", str(out)])
    assert result.exit_code == 2
    line = _one_line_error(result)
    assert "UTF-8" not in line and "two" in line and "machine file" in line


def test_lump_does_not_replace_a_hand_written_machine_file(tmp_path):
    """`lump -o` over a machine file that lump did not write needs --force (docs/results.md)."""
    parts = tmp_path / "parts.toml"
    shutil.copy(MACHINES / "cdtm-parts.toml", parts)
    target = tmp_path / "cdtm.toml"
    shutil.copy(MACHINES / "cdtm.toml", target)
    before = target.read_bytes()
    result = runner.invoke(app, ["lump", str(parts), "-o", str(target)])
    assert result.exit_code == 2
    assert "--force" in _one_line_error(result)
    assert target.read_bytes() == before
    again = runner.invoke(app, ["lump", str(parts), "-o", str(tmp_path / "lumped.toml")])
    assert again.exit_code == 0, again.stderr
    # lump's own result is replaced without --force
    assert runner.invoke(app, ["lump", str(parts), "-o", str(tmp_path / "lumped.toml")]).exit_code == 0
    assert runner.invoke(app, ["lump", str(parts), "-o", str(target), "--force"]).exit_code == 0


def test_export_never_writes_over_a_file_of_another_kind(machine):
    """`export -o` onto a TOML file named .csv is refused by its bytes, not its name."""
    out = machine.parent / "r.h5"
    assert runner.invoke(app, ["run", str(machine), "-o", str(out), "-q", *FAST]).exit_code == 0
    fake = machine.parent / "notes.csv"
    shutil.copy(machine, fake)
    before = fake.read_bytes()
    result = runner.invoke(app, ["export", str(out), "-o", str(fake)])
    assert result.exit_code == 2
    assert "TOML" in _one_line_error(result)
    assert fake.read_bytes() == before
    result = runner.invoke(app, ["export", str(out), "-o", str(machine.parent / "r.toml")])
    assert result.exit_code == 2 and "'.toml'" in _one_line_error(result)


def test_cam_outputs_with_the_same_name_are_refused(machine):
    """`cam -o x.csv --profile x.csv` would write one file over the other."""
    shutil.copy(MACHINES / "cdtm-geometry.toml", machine)
    out = machine.parent / "x.csv"
    result = runner.invoke(app, ["cam", str(machine), "-o", str(out), "--profile", str(out)])
    assert result.exit_code == 2
    assert "same file" in _one_line_error(result)
    assert not out.exists()


def test_absurd_stiffness_is_bad_input_not_a_traceback(machine):
    """Issue 26: `--set element.k12.stiffness="1e300 N/m"` ended in a traceback. Now exit 2, one
    line (issue 45: refused when loaded, beyond the range camsim computes with; 1e29 N/m names
    the natural frequency), nothing written."""
    dyn = machine.parent / "dyn.toml"
    shutil.copy(MACHINES / "dynacam-2mass.toml", dyn)
    result = runner.invoke(app, ["run", str(dyn), "--set", "element.k12.stiffness=1e300 N/m", "-o",
                                 str(machine.parent / "big.h5"), "-q"])
    assert result.exit_code == 2, result.stderr
    assert "beyond the range" in _one_line_error(result)
    result = runner.invoke(app, ["run", str(dyn), "--set", "element.k12.stiffness=1e29 N/m", "-o",
                                 str(machine.parent / "big.h5"), "-q"])
    assert result.exit_code == 2, result.stderr
    assert "natural frequency" in _one_line_error(result)
    assert not (machine.parent / "big.h5").exists()


def test_warnings_follow_units_us(tmp_path):
    """Issue 26: warnings ignored --units us. The negative-cam-force warning of the DYNACAM
    model at 400 rpm shows lbf under --units us and N under --units si (issue 36: no SI value
    beside it); reference: 1 lbf = 4.4482216152605 N (exact by definition), to the 4 printed digits."""
    import re

    dyn = tmp_path / "dyn.toml"
    shutil.copy(MACHINES / "dynacam-2mass.toml", dyn)
    minimum = {}
    for system, unit in (("us", "lbf"), ("si", "N")):
        result = runner.invoke(app, ["run", str(dyn), "--set", "cam.speed=400 rpm", "-o", str(tmp_path / f"w{system}.h5"),
                                     "-q", "--units", system])
        assert result.exit_code == 0, result.stderr
        line = next(l for l in result.stderr.splitlines() if l.startswith("warning: cam contact force"))
        m = re.search(rf"minimum (\S+) {unit}\b", line)
        assert m, line
        assert " N" not in line if system == "us" else "lbf" not in line
        minimum[system] = float(m.group(1))
    assert minimum["us"] == pytest.approx(minimum["si"] / 4.4482216152605, rel=1e-3)
