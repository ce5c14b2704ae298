"""``camsim impact``: closed-form impact-force estimates, and ``camsim impact fit``.

A thin layer over :func:`camsim.physics.impact.estimate_impact` and
:func:`camsim.physics.impact.fit_power_law`; every value is a string with its unit, parsed by
:func:`camsim.units.to_si`.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import typer
from rich.markup import escape
from rich.table import Table

from camsim.cli.app import app, err_console, fail, print_json, user_errors, warn
from camsim.cli.units_option import check_units, units_option
from camsim.errors import InputError
from camsim.units import QuantityError, to_si

from camsim.units import LBF  # noqa: E402

if TYPE_CHECKING:
    from camsim.display import DisplayUnits
    from camsim.physics import impact

impact_app = typer.Typer(
    name="impact",
    invoke_without_command=True,
    no_args_is_help=True,
    add_completion=False,
    context_settings={"help_option_names": ["-h", "--help"]},
    rich_markup_mode=None,
    help=(
        "Estimate the peak force of a striking impact (Johnson's common-velocity bounds, "
        "Burr's deflection and correction factor, Burr's wave method; thesis §3.3), or fit "
        "a power-law contact to force-deflection data with 'camsim impact fit'. "
        "Values are quantities with their units, quoted; results in the units written (--units)."
    ),
    epilog="See docs/impact.md for the formulas and their sources (the examples below: camsim.cli.helptext).",
)
app.add_typer(impact_app, name="impact")

_UNITS_HELP = 'a quantity with its unit, e.g. '

# Calculator options and their defaults, to tell whether any was given with 'fit'.
_CALCULATOR_DEFAULTS: dict[str, Any] = {
    "mass": None,
    "velocity": None,
    "drop_height": None,
    "target_mass": None,
    "stiffness": None,
    "coefficient": None,
    "exponent": None,
    "sphere_diameter": None,
    "bar_area": None,
    "bar_length": None,
    "modulus": None,
    "density": None,
    "eta": None,
    "gravity": None,
}


def _quantity(option: str, value: str | None, dimension: str) -> float | None:
    if value is None:
        return None
    try:
        return to_si(value, dimension)
    except QuantityError as exc:
        raise InputError(f"{option}: {exc}") from None


def _positive(option: str, value: float | None, text: str | None, what: str = "") -> None:
    if value is not None and not value > 0:
        raise InputError(f'{option} must be positive{what}, got "{text}"')


def _number(option: str, text: str | None) -> float | None:
    if text is None:
        return None
    try:
        value = float(text)
    except ValueError:
        raise InputError(f'{option}: expected a number, got "{text}"') from None
    if not math.isfinite(value):
        raise InputError(f'{option}: expected a finite number, got "{text}"')
    return value


@impact_app.callback()
def impact_command(
    ctx: typer.Context,
    mass: str = typer.Option(
        None, "--mass", metavar="QTY", help=_UNITS_HELP + '"0.0079 lb", "2.029e-5 lbf*s**2/in": the striking mass.'
    ),
    velocity: str = typer.Option(
        None,
        "--velocity",
        metavar="QTY",
        help=_UNITS_HELP + '"1.2 m/s", "70 in/s": approach speed towards the target (> 0).',
    ),
    drop_height: str = typer.Option(
        None,
        "--drop-height",
        metavar="QTY",
        help=_UNITS_HELP + '"1 in": drop from rest; v = sqrt(2 g h). Instead of --velocity.',
    ),
    target_mass: str = typer.Option(
        None,
        "--target-mass",
        metavar="QTY",
        help=_UNITS_HELP + '"2 kg". Default: a fixed target (infinite mass).',
    ),
    stiffness: str = typer.Option(
        None,
        "--stiffness",
        metavar="QTY",
        help=_UNITS_HELP + '"60800 lbf/in": linear contact rate (Johnson linear, Burr).',
    ),
    coefficient: str = typer.Option(
        None,
        "--coefficient",
        metavar="QTY",
        help=_UNITS_HELP + '"1.11e7 lbf/in**1.425": C of a power-law contact F = C*d^a '
        "(Johnson power law); needs --exponent.",
    ),
    exponent: str = typer.Option(
        None, "--exponent", metavar="NUMBER", help='a of F = C*d^a, a number > 0, e.g. "1.425".'
    ),
    sphere_diameter: str = typer.Option(
        None,
        "--sphere-diameter",
        metavar="QTY",
        help=_UNITS_HELP + '"0.375 in": a sphere on a flat of the same material (nu ~ 0.3); '
        "sets C = 0.518 E sqrt(D), a = 1.5 from --modulus, instead of --coefficient/--exponent.",
    ),
    bar_area: str = typer.Option(
        None, "--bar-area", metavar="QTY", help=_UNITS_HELP + '"0.0276 in**2": struck bar cross-section (wave).'
    ),
    bar_length: str = typer.Option(
        None,
        "--bar-length",
        metavar="QTY",
        help=_UNITS_HELP + '"0.4 in": struck bar length, fixed at the far end (wave).',
    ),
    modulus: str = typer.Option(
        None, "--modulus", metavar="QTY", help=_UNITS_HELP + '"2.9e7 psi": Young\'s modulus (wave, --sphere-diameter).'
    ),
    density: str = typer.Option(
        None, "--density", metavar="QTY", help=_UNITS_HELP + '"7850 kg/m**3", "0.284 lb/in**3": bar density (wave).'
    ),
    eta: str = typer.Option(
        None,
        "--eta",
        metavar="NUMBER",
        help="Burr's correction factor, a number in (0, 1]. Default: 1 for a fixed target, "
        "else m/(m + M/3) with M the target mass.",
    ),
    gravity: str = typer.Option(
        None,
        "--gravity",
        metavar="QTY",
        help=_UNITS_HELP + '"386.4 in/s**2": for --drop-height and Burr\'s weight. Default 9.80665 m/s**2.',
    ),
    json_out: bool = typer.Option(False, "--json", help="Print the estimates as JSON on stdout."),
    materials: bool = typer.Option(False, "--materials", help="Rank material pairs for a Hertz contact of a machine "
                                   "(--machine) by simulated peak force, contact stress against yield, and rebound."),
    machine: Path = typer.Option(None, "--machine", metavar="FILE", help="With --materials: the machine file."),
    contact: str = typer.Option(None, "--contact", metavar="NAME", help="With --materials: the contact (default: the "
                                "machine's only law = \"hertz\" contact)."),
    pair: list[str] = typer.Option([], "--pair", metavar="BODY,FLAT", help="With --materials: a pair to try "
                                   "(repeatable); default every pair of the library."),
    candidates: str = typer.Option(None, "--candidates", metavar="A,B,...", help="With --materials: every pair of "
                                   "these materials."),
    set_: list[str] = typer.Option([], "--set", metavar="KEY=VALUE", help="With --materials: override a machine key."),
    workers: int = typer.Option(1, "--workers", min=1, help="With --materials: processes running the pairs."),
    units: str = units_option("Units of the table: file (the units written in the options, per dimension: "
                              "--stiffness \"60800 lbf/in\" shows forces in lbf; the default), si or us. --json has N and lbf."),
) -> None:
    """Estimate the peak force of a striking impact.

    Prints every estimate the inputs allow, in the units of the options (--units): Johnson's lower and upper bounds
    (--stiffness, or --coefficient/--exponent, or --sphere-diameter with --modulus),
    Burr's deflection and correction factor (--stiffness) and Burr's wave method (--bar-area,
    --bar-length, --modulus, --density). Values are quantities with units, in quotes.
    See docs/impact.md.
    """
    given = {
        "mass": mass,
        "velocity": velocity,
        "drop_height": drop_height,
        "target_mass": target_mass,
        "stiffness": stiffness,
        "coefficient": coefficient,
        "exponent": exponent,
        "sphere_diameter": sphere_diameter,
        "bar_area": bar_area,
        "bar_length": bar_length,
        "modulus": modulus,
        "density": density,
        "eta": eta,
        "gravity": gravity,
    }
    if materials:  # issue 39: the thesis's third recommendation as a command
        from camsim.cli.impact_materials import materials_command

        extra = [name for name, value in given.items() if value != _CALCULATOR_DEFAULTS[name]]
        if extra:
            raise fail(f"--{extra[0].replace('_', '-')} is a calculator option; --materials takes a machine file")
        from camsim.run.lifecycle import sigterm_as_interrupt

        with user_errors(), sigterm_as_interrupt():  # issue 45: SIGTERM stops the pairs as Ctrl-C does
            materials_command(machine, contact, pair, candidates, set_, workers, json_out, units)
        return
    if any((machine, contact, pair, candidates, set_)):
        raise fail("--machine, --contact, --pair, --candidates and --set go with --materials")
    if ctx.invoked_subcommand is not None:
        extra = [name for name, value in given.items() if value != _CALCULATOR_DEFAULTS[name]]
        if extra:
            raise fail(
                f"--{extra[0].replace('_', '-')} is a calculator option; "
                f"'camsim impact {ctx.invoked_subcommand}' does not take it"
            )
        ctx.obj = {"json": json_out}
        return
    with user_errors():
        check_units(units)
        inputs, estimates = _calculate(**given)
        from camsim.display import display_units

        shown = display_units(units, None, [v for v in given.values() if v is not None])
        _bare_numbers(given, shown)
    if json_out:
        print_json(_payload(inputs, estimates))
    else:
        _print_table(inputs, estimates, shown)


#: The dimension of each quantity option (for the bare-number warning).
_DIMENSION = {"mass": "mass", "velocity": "velocity", "drop_height": "length", "target_mass": "mass",
              "stiffness": "stiffness", "sphere_diameter": "length", "bar_area": "area", "bar_length": "length",
              "modulus": "pressure", "density": "density", "gravity": "acceleration"}


def _bare_numbers(given: dict[str, str | None], shown) -> None:
    """Issue 44: a bare number is SI, and the warning says so with the value in the table's units."""
    from camsim.machine.keys import bare_number_note
    from camsim.units import DIMENSIONS

    for name, dimension in _DIMENSION.items():
        note = bare_number_note(f"--{name.replace('_', '-')}", given[name], DIMENSIONS[dimension], shown) \
            if given[name] is not None else None
        if note:
            warn(note)


def _calculate(**given: str | None) -> tuple[dict[str, Any], impact.ImpactEstimates]:
    """Parse and check the options, then call :func:`camsim.physics.impact.estimate_impact`."""
    from camsim.physics import impact  # numpy: only when the command runs
    if given["mass"] is None:
        raise InputError("--mass is required (the striking mass, e.g. --mass \"0.0079 lb\")")
    if (given["velocity"] is None) == (given["drop_height"] is None):
        raise InputError("give exactly one of --velocity and --drop-height")
    si = {
        "mass": _quantity("--mass", given["mass"], "mass"),
        "velocity": _quantity("--velocity", given["velocity"], "velocity"),
        "drop_height": _quantity("--drop-height", given["drop_height"], "length"),
        "target_mass": _quantity("--target-mass", given["target_mass"], "mass"),
        "stiffness": _quantity("--stiffness", given["stiffness"], "stiffness"),
        "sphere_diameter": _quantity("--sphere-diameter", given["sphere_diameter"], "length"),
        "bar_area": _quantity("--bar-area", given["bar_area"], "area"),
        "bar_length": _quantity("--bar-length", given["bar_length"], "length"),
        "modulus": _quantity("--modulus", given["modulus"], "pressure"),
        "density": _quantity("--density", given["density"], "density"),
        "gravity": _quantity("--gravity", given["gravity"], "acceleration"),
        "exponent": _number("--exponent", given["exponent"]),
        "eta": _number("--eta", given["eta"]),
    }
    for key, what in (
        ("mass", ""),
        ("velocity", " (the approach speed of the striking mass towards the target)"),
        ("drop_height", ""),
        ("target_mass", ""),
        ("stiffness", ""),
        ("sphere_diameter", ""),
        ("bar_area", ""),
        ("bar_length", ""),
        ("modulus", ""),
        ("density", ""),
        ("gravity", ""),
        ("exponent", ""),
    ):
        _positive("--" + key.replace("_", "-"), si[key], given[key], what)
    if si["eta"] is not None and not 0 < si["eta"] <= 1:
        raise InputError(f'--eta must be in (0, 1], got "{given["eta"]}"')
    if si["eta"] is not None and si["stiffness"] is None:
        raise InputError("--eta applies to the Burr estimate, which needs --stiffness")

    if given["sphere_diameter"] is not None:
        if given["coefficient"] is not None or given["exponent"] is not None:
            raise InputError("give either --sphere-diameter or --coefficient/--exponent, not both")
        if si["modulus"] is None:
            raise InputError("--sphere-diameter needs --modulus (C = 0.518 E sqrt(D))")
        si["exponent"] = impact.HERTZ_SPHERE_EXPONENT
        si["coefficient"] = float(impact.hertz_sphere_coefficient(si["modulus"], si["sphere_diameter"]))
    elif (given["coefficient"] is None) != (given["exponent"] is None):
        raise InputError(
            "--coefficient needs --exponent" if given["exponent"] is None else "--exponent needs --coefficient"
        )
    elif given["coefficient"] is not None:
        si["coefficient"] = _quantity(
            "--coefficient", given["coefficient"], f"power_coefficient:{si['exponent']!r}"
        )
        _positive("--coefficient", si["coefficient"], given["coefficient"])
    else:
        si["coefficient"] = None

    bar_options = ("bar_area", "bar_length", "density") + (
        ("modulus",) if given["sphere_diameter"] is None else ()
    )
    bar_given = [key for key in ("bar_area", "bar_length", "modulus", "density") if given[key] is not None]
    if any(given[key] is not None for key in bar_options):
        absent = [key for key in ("bar_area", "bar_length", "modulus", "density") if given[key] is None]
        if absent:
            raise InputError(
                "the wave estimate needs " + ", ".join("--" + k.replace("_", "-") for k in absent)
            )
        wave_inputs = {key: si[key] for key in bar_given}
    else:
        wave_inputs = {}

    if si["stiffness"] is None and si["coefficient"] is None and not wave_inputs:
        raise InputError(
            "no estimate possible: give --stiffness (Johnson linear, Burr), --coefficient and "
            "--exponent or --sphere-diameter (Johnson power law), or --bar-area, --bar-length, "
            "--modulus, --density (wave)"
        )
    estimates = impact.estimate_impact(
        si["mass"],
        si["velocity"],
        drop_height=si["drop_height"],
        target_mass=math.inf if si["target_mass"] is None else si["target_mass"],
        stiffness=si["stiffness"],
        coefficient=si["coefficient"],
        exponent=si["exponent"] if si["coefficient"] is not None else None,
        eta=si["eta"],
        gravity=impact.STANDARD_GRAVITY if si["gravity"] is None else si["gravity"],
        **wave_inputs,
    )
    inputs = {
        "mass_kg": si["mass"],
        "velocity_m_per_s": estimates.velocity,
        "drop_height_m": si["drop_height"],
        "target_mass_kg": si["target_mass"],  # null: fixed target
        "stiffness_N_per_m": si["stiffness"],
        "coefficient_N_per_m_pow_a": si["coefficient"],
        "exponent": si["exponent"] if si["coefficient"] is not None else None,
        "sphere_diameter_m": si["sphere_diameter"],
        "bar_area_m2": si["bar_area"],
        "bar_length_m": si["bar_length"],
        "modulus_Pa": si["modulus"],
        "density_kg_per_m3": si["density"],
        "eta": estimates.eta,
        "gravity_m_per_s2": impact.STANDARD_GRAVITY if si["gravity"] is None else si["gravity"],
    }
    return inputs, estimates


def _lbf(value: float | None) -> float | None:
    return None if value is None else value / LBF


def _payload(inputs: dict[str, Any], est: impact.ImpactEstimates) -> dict[str, Any]:
    forces = {
        "johnson_lower": est.johnson_lower,
        "johnson_upper": est.johnson_upper,
        "burr": est.burr,
        "wave": est.wave,
    }
    payload: dict[str, Any] = {f"{key}_N": value for key, value in forces.items()}
    payload.update({f"{key}_lbf": _lbf(value) for key, value in forces.items()})
    payload["johnson_law"] = est.johnson_law
    payload["inputs"] = inputs
    return payload


_OPTION_OF = {
    "stiffness": "--stiffness",
    "coefficient": "--coefficient",
    "exponent": "--exponent",
    "bar_area": "--bar-area",
    "bar_length": "--bar-length",
    "modulus": "--modulus",
    "density": "--density",
}


def _needs(est: impact.ImpactEstimates, key: str, inputs: dict[str, Any]) -> str:
    if key == "johnson":
        return "needs --stiffness, or --coefficient and --exponent"
    given = {"modulus"} if inputs["modulus_Pa"] is not None else set()
    return "needs " + ", ".join(_OPTION_OF[name] for name in est.missing[key] if name not in given)


def _print_table(inputs: dict[str, Any], est: impact.ImpactEstimates, units: DisplayUnits) -> None:
    law = {"linear": "linear k", "power": "power law C*d^a", None: ""}[est.johnson_law]
    target = (
        "fixed target"
        if inputs["target_mass_kg"] is None
        else f"target {units.quantity(inputs['target_mass_kg'], 'kg', '.6g')}"
    )
    table = Table(
        title=(
            f"Impact of {units.quantity(inputs['mass_kg'], 'kg', '.6g')} at {units.quantity(est.velocity, 'm/s', '.6g')} "
            f"on a {target}"
        ),
        title_justify="left",
    )
    force_unit, k = units.shown("N")
    table.add_column("estimate")
    table.add_column("source")
    table.add_column(escape(f"force [{force_unit}]"), justify="right")
    rows = [
        ("Johnson lower (finite mass)", f"thesis eq. 3.27/3.34, {law}", est.johnson_lower, "johnson"),
        ("Johnson upper (infinite mass)", f"thesis eq. 3.29/3.35, {law}", est.johnson_upper, "johnson"),
        (
            "Burr deflection & correction",
            "thesis eq. 3.16/3.23" + (f", eta = {est.eta:.4g}" if est.eta is not None else ""),
            est.burr,
            "burr",
        ),
        ("Burr wave method", "thesis eq. 3.49, bar fixed at far end", est.wave, "wave"),
    ]
    for name, source, value, key in rows:
        if value is None:
            table.add_row(name, _needs(est, key, inputs), "-")
        else:
            table.add_row(name, source, f"{value * k:.6g}")
    err_console.print(table)


# ------------------------------------------------------------------------------ fit

@impact_app.command("fit")
def fit_command(
    ctx: typer.Context,
    data: Path = typer.Argument(
        ...,
        metavar="DATA",
        help='Force-deflection samples; header with units in brackets, e.g. "deflection [in],force [lbf]".',
    ),
    json_out: bool = typer.Option(False, "--json", help="Print C, a and R² as JSON on stdout."),
    units: str = units_option("Units of C in the table: file (the data file's, e.g. lbf/in^a for a header "
                              "\"deflection [in],force [lbf]\"; the default), si (N/m^a) or us (lbf/in^a). --json has both."),
) -> None:
    """Fit a power-law contact F = C*d^a to force-deflection data (log-log least squares).

    Prints C in the data file's units (--units), the exponent a and R^2 of the log-log fit.
    At least 3 samples, all positive.
    """
    from camsim.io.forcedeflection import read_force_deflection_csv
    from camsim.physics import impact  # numpy: only when the command runs

    json_out = json_out or bool((ctx.obj or {}).get("json"))
    with user_errors():
        check_units(units)
        samples = read_force_deflection_csv(data)
        deflection, force = samples.deflection, samples.force
        length_unit, force_unit = samples.deflection_unit, samples.force_unit
        for label, values, unit in (("deflection", deflection, length_unit), ("force", force, force_unit)):
            scale = to_si(f"1 {unit}", "force" if label == "force" else "length")
            for number, value in zip(samples.lines, values):
                if not value > 0:
                    raise InputError(
                        f"{data}: line {number}: {label} must be positive for a log-log fit, "
                        f"got {value / scale:g} {unit}"
                    )
        try:
            fit = impact.fit_power_law(deflection, force)
        except InputError as exc:
            raise InputError(f"{data}: {exc}") from None
    file_coefficient, file_unit = impact.coefficient_in_units(fit.coefficient, fit.exponent, force_unit, length_unit)
    if json_out:
        print_json(
            {
                "coefficient_N_per_m_pow_a": fit.coefficient,
                "exponent": fit.exponent,
                "r_squared": fit.r_squared,
                "coefficient_in_file_units": file_coefficient,
                "file_coefficient_unit": file_unit,
                "points": len(force),
            }
        )
        return
    table = Table(title=escape(f"Power-law fit F = C*d^a of {data} ({len(force)} points)"), title_justify="left")
    table.add_column("quantity")
    table.add_column("value", justify="right")
    table.add_column("unit")
    if units == "file":
        table.add_row("C", f"{file_coefficient:.6g}", escape(file_unit.replace("**", "^")))
    else:
        from camsim.display import display_units

        c_unit, c_k = display_units(units).power_coefficient(fit.exponent)
        table.add_row("C", f"{fit.coefficient * c_k:.6g}", escape(c_unit))
    table.add_row("a", f"{fit.exponent:.6g}", "-")
    table.add_row("R² (log-log)", f"{fit.r_squared:.6f}", "-")
    err_console.print(table)


# What the command reads and writes (camsim.cli.contracts; the conformance suite's source).
from camsim.cli.contracts import Reads, declare
declare("impact", reads=[Reads("machine", "machine", example=("impact", "--materials", "--machine", "{in:machine}"))],
        example=("impact", "--mass", "1 kg", "--velocity", "1 m/s", "--stiffness", "1e6 N/m"))
declare("impact fit", reads=[Reads("data", "csv", fixture="deflection")], example=("impact", "fit", "{in:data}"))
