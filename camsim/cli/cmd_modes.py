"""``camsim modes``: natural frequencies, damping ratios and stiffness ratio per configuration."""

from __future__ import annotations

import math
from pathlib import Path

import typer
from rich.markup import escape
from rich.table import Table

from camsim.cli.app import app, err_console, print_json, user_errors, warn_notes
from camsim.cli.units_option import check_units, units_option


@app.command("modes")
def modes_command(
    machine: Path = typer.Argument(..., help="Machine file (TOML)."),
    set_: list[str] = typer.Option([], "--set", help="Override a machine key (repeatable)."),
    json_: bool = typer.Option(False, "--json", help="Print the modes as JSON on stdout."),
    units: str = units_option("Units of the human output, as for every command: file (the default), si or us. Natural "
                              "frequencies are in Hz and damping ratios are numbers in every system."),
) -> None:
    """Natural frequencies [Hz] and damping ratios of every branch configuration.

    One row per combination of over-travel links (joined/separated) and contacts
    (open/closed/stuck). The stiffness ratio is the highest over the lowest natural
    frequency (thesis §7.2.1: above ~200 the system is stiff). Configurations with a
    closed power-law contact list only their linear part (marked nonlinear).
    """
    from camsim.machine.loader import load_machine
    from camsim.analyses.modes import machine_modes, modes_to_dict, rod_modes

    with user_errors():
        check_units(units)
        loaded = load_machine(machine, overrides=set_)
        warn_notes(loaded)
        modes = machine_modes(loaded)
        rods = rod_modes(loaded)
    if json_:
        print_json(modes_to_dict(modes, rods))
        return
    table = Table(title=f"{loaded.name}: modes per configuration", title_justify="left")
    table.add_column("configuration")
    table.add_column("natural frequencies [Hz]", justify="right")
    table.add_column("damping ratios", justify="right")
    table.add_column("stiffness ratio", justify="right")
    for m in modes:
        label = ", ".join(f"{k} {v}" for k, v in m.branches.items()) or "(no contacts or links)"
        if m.nonlinear:
            label += " (nonlinear)"
        table.add_row(
            label,
            ", ".join(f"{f:.4g}" for f in m.frequencies) or "–",
            ", ".join("–" if math.isnan(z) else f"{z:.3g}" for z in m.damping_ratios) or "–",
            f"{m.stiffness_ratio:.3g}" if m.stiffness_ratio else "–",
        )
    err_console.print(table)
    for note in _dash_notes(modes):  # issue 35: every "–" says why
        err_console.print(note, markup=False)
    for rod in rods:  # issue 39: each rod's own axial modes, free at both ends
        t = Table(title=escape(f"rod {rod['rod']}: {rod['segments_reason']}"), title_justify="left")
        for col in ("mode", "lumped [Hz]", "continuum j*c/2L [Hz]", "error", "damping ratio"):
            t.add_column(escape(col), justify="right")
        for j, (f, g, e, z) in enumerate(zip(rod["lumped_hz"], rod["continuum_hz"], rod["error"], rod["damping_ratios"]), 1):
            t.add_row(str(j), f"{f:.5g}", f"{g:.5g}", f"{100 * e:+.3g} %", f"{z:.3g}")
        err_console.print(t)
        err_console.print(f"highest mode of the discretisation: {rod['highest_hz']:.5g} Hz (the machine's configurations "
                          "above include the rod, coupled to its nodes)", markup=False)


def _dash_notes(modes) -> list[str]:
    notes = []
    if any(not m.frequencies for m in modes):
        notes.append("natural frequencies –: no mass is free to move in that configuration")
    if any(math.isnan(z) for m in modes for z in m.damping_ratios) or any(not m.damping_ratios for m in modes):
        notes.append("damping ratios –: a rigid-body mode (0 Hz) has no damping ratio")
    if any(not m.stiffness_ratio for m in modes):
        notes.append("stiffness ratio –: needs two non-zero natural frequencies")
    return notes


# What the command reads and writes (camsim.cli.contracts; the conformance suite's source).
from camsim.cli.contracts import Reads, declare
declare("modes", reads=[Reads("machine", "machine")], example=("modes", "{in:machine}"))
