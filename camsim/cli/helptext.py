"""``--help`` of every command: examples, defaults, and metavars a user reads (issue 44).

Typer describes an option by its Python annotation (``<list[str]>``, ``<int range>``) and a
required argument as ``{machine}``; a default that the machine file supplies (``--cycles``)
shows nothing. :func:`polish` runs over the click commands once before the command line is
parsed and gives

* every argument its name in capitals (``MACHINE``) and every option without one a metavar
  from its type (``PATH``, ``N``, ``NUMBER``, ``TEXT``, ``KEY=VALUE`` for ``--set``);
* every option whose default is a value its ``[default: …]``; an option whose default is the
  machine file's or another command's says so in its help (``tests/cli/test_help.py`` checks
  both);
* every command an ``Examples:`` section from :data:`EXAMPLES`, commands that run as shown
  from the repository's root (the examples are parsed by the test, the files they name exist).
"""

from __future__ import annotations

from typing import Any

__all__ = ["CYCLES_HELP", "EXAMPLES", "SAMPLE_RATE_HELP", "WARMUP_HELP", "polish"]

#: Help of the run settings every simulating command takes (issue 44: their defaults are said).
CYCLES_HELP = "Recorded revolutions (default: the machine file's simulation.cycles; 1 when it has none)."
WARMUP_HELP = "Revolutions computed and discarded first (default: the machine file's simulation.warmup_cycles; 1 when it has none)."
SAMPLE_RATE_HELP = ('Output sample rate with units, e.g. "50 kHz" (bare number: Hz; default: the machine file\'s '
                    "simulation.sample_rate, 50 kHz when it has none).")


#: Command path → example command lines (a ``#`` comment may follow a command).
EXAMPLES: dict[str, tuple[str, ...]] = {
    "validate": ("camsim validate machines/cdtm.toml",
                 'camsim validate machines/cdtm.toml --set cam.speed="150 rpm" --json'),
    "cam": ("camsim cam machines/cdtm.toml",
            "camsim cam machines/cdtm-geometry.toml --plot cam.png --profile cam.csv"),
    "run": ("camsim run machines/cdtm.toml -o cdtm.h5",
            "camsim run machines/cdtm.toml -o cdtm.h5 --cycles 3 --record 'transducer/*' --report cdtm.html"),
    "modes": ("camsim modes machines/cdtm.toml",),
    "compare": ("camsim compare machines/cdtm.toml -o cdtm_compare.h5",
                "camsim compare cdtm.h5 cdtm_new.h5           # two result files"),
    "plot": ("camsim plot cdtm.h5 --what masses --mass M3 -o plots",
             "camsim plot cdtm_sweep.h5"),
    "export": ("camsim export cdtm.h5 --columns transducer/force --units file -o force.csv",),
    "check": ("camsim check cdtm.h5 --against tests/data/golden/cdtm.h5 --show 30",),
    "sweep": ("camsim sweep machines/cdtm.toml --vary cam.speed=60:600:10rpm -o cdtm_sweep.h5",
              "camsim sweep machines/barkan-follower.toml --vary cam.speed=400:500:10rpm --refine-jump"),
    "lump": ("camsim lump machines/cdtm-parts.toml -o cdtm-lumped.toml",),
    "fit": ("camsim fit machines/cdtm.toml examples/rig_trace.csv --param element.K23.push_stiffness=6000:10000lbf/in "
            "-o cdtm_fitted.toml",),
    "study": ('camsim study machines/cdtm.toml --dist element.K23.preload=tol:28.12:3lbf '
              '--limit "peak_transducer_force>52lbf" -n 256 -o cdtm_study.h5',),
    "optimize": ("camsim optimize machines/cdtm.toml --var element.K23.preload=20:40lbf --minimize peak_transducer_force "
                 "-o cdtm_optimum.toml",),
    "report": ("camsim report cdtm.h5 -o cdtm.html",
               "camsim report cdtm.h5 -o cdtm.html --pdf cdtm.pdf"),
    "impact": ("# thesis appendix C, table 6: a 0.375 in steel ball dropped 1 in on the hard stop",
               'camsim impact --mass "2.029e-5 lbf*s**2/in" --drop-height "1 in" --sphere-diameter "0.375 in" '
               '--modulus "2.9e7 psi" --stiffness "60800 lbf/in"',
               "camsim impact --materials --machine machines/ball-drop-hertz.toml --candidates steel,bronze"),
    "impact fit": ("camsim impact fit seat.csv            # columns: deflection [in], force [lbf]",),
}

#: Metavars of options that take the same kind of value in every command.
_BY_NAME = {"--set": "KEY=VALUE", "--units": "file|si|us", "--sample-rate": "RATE", "--workers": "N",
            "--cycles": "N", "--warmup": "N", "--seed": "N", "--samples": "N", "--budget": "N", "--show": "N",
            "--points": "N"}


def _metavar(param: Any) -> str:
    """A metavar a user reads, from the option's name or its type."""
    for opt in getattr(param, "opts", ()):
        if opt in _BY_NAME:
            return _BY_NAME[opt]
    bare = param.bare_type().lower() if hasattr(param, "bare_type") else type(getattr(param, "type", None)).__name__.lower()
    bare = bare.replace("list[", "").replace("]", "")
    if "path" in bare:
        return "PATH"
    if bare.startswith("int"):
        return "N"
    if bare.startswith("float"):
        return "NUMBER"
    return "TEXT"


def _walk(group: Any, prefix: str = ""):
    for name, cmd in getattr(group, "commands", {}).items():
        path = f"{prefix} {name}".strip()
        yield path, cmd
        yield from _walk(cmd, path)


def polish(group: Any) -> None:
    """Metavars, defaults and examples of every command under ``group`` (idempotent)."""
    if getattr(group, "_camsim_polished", False):
        return
    for path, cmd in _walk(group):
        for p in cmd.params:
            if getattr(p, "param_type_name", "") == "argument":
                p.metavar = p.metavar or p.name.upper()
                # the usage line and the argument's help row: MACHINE, not {machine} / machine <path>
                p._usage_display_name = (lambda p=p: p.metavar + ("..." if p.nargs != 1 and not p.metavar.endswith("...")
                                                                   else ""))
                p.display_type_rich = lambda ctx: None
                continue
            if getattr(p, "is_flag", False) or getattr(p, "hidden", False) or p.name in ("help",):
                continue
            if p.metavar is None:
                p.metavar = _metavar(p) + ("..." if getattr(p, "multiple", False) else "")
            if p.default not in (None, (), [], False, "") and not callable(p.default):
                p.show_default = True
        examples = EXAMPLES.get(path)
        if examples:
            block = "\b\nExamples:\n" + "\n".join(f"  {line}" for line in examples)
            cmd.epilog = block + (f"\n\n{cmd.epilog}" if cmd.epilog else "")
    group._camsim_polished = True
