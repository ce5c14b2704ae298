"""The figure of an optimisation (``camsim optimize --plot opt.png``).

Three panels:

* convergence: each candidate's first objective (grey: infeasible) and the best feasible
  value so far, against the evaluation number;
* the Pareto front (``--method pareto``) over every evaluated candidate, or else the first
  objective at each speed, the file's machine against the optimum;
* the response: the trace the first objective reads (``transducer/force`` for
  ``peak_transducer_force``, the PATH of ``REDUCER:PATH``, ...) over one revolution, the
  file's machine (dashed) against the optimum (solid), at every speed. Skipped when the
  objective reads no trace (``param:KEY``).

Rendering is deterministic (Agg, no timestamps in the file).
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np

__all__ = ["plot_optimize", "save_optimize_plot", "objective_trace"]



def objective_trace(text: str) -> str | None:
    """The trace path an objective expression reads (None if it reads none)."""
    from camsim.analyses.study.outputs import OutputExpr, ParamExpr, parse_expression

    e = parse_expression(text)
    if isinstance(e, OutputExpr):
        return e.path
    if isinstance(e, ParamExpr):
        return None
    name = e.text
    if name == "peak_transducer_force":
        return "transducer/force"
    if name in ("min_cam_contact_force", "max_cam_contact_force", "peak_normal_force"):
        return "cam_contact/force"
    if name.startswith("peak_") and ":" in name:
        q, mass = name[5:].split(":", 1)
        return f"masses/{mass}/{q}"
    if "hertz" in name:
        return "cam_contact/hertz_stress"
    if "torque" in name:
        return "cam/torque"
    return None


def _responses(result):
    """(speed, angle, file trace, optimum trace) per speed, or [] when there is nothing to draw."""
    from camsim.analyses.sweep.runner import MachineSource
    from camsim.run.simulation import simulate

    path = objective_trace(result.problem.goals[0].text)
    if path is None or result.best is None:
        return None, []
    source = MachineSource(text=result.source_text, source=result.source_name,
                           base_dir=str(Path(result.source_name).parent) if result.source_name else ".")
    p = result.problem
    best = []
    for v in p.variables:
        best.append(v.assignment(result.best.values[v.key]))
    if p.absorb is not None:
        from camsim.analyses.optimize.problem import assignment

        best.append(assignment(p.absorb, float(result.best.values[p.absorb])))
    out = []
    for speed in p.speeds:
        sp = [] if speed is None else [f"cam.speed={speed!r}"]
        try:
            a = simulate(source.load(result.fixed + sp))
            b = simulate(source.load(result.fixed + best + sp))
            out.append((speed, np.mod(a.trace("cam/angle"), 360.0), a.trace(path), np.mod(b.trace("cam/angle"), 360.0),
                        b.trace(path), a.units(path)))
        except Exception:  # noqa: BLE001 - a trace this machine lacks: no response panel
            return path, []
    return path, out


def plot_optimize(result, units=None):
    """Build the figure (a :class:`matplotlib.figure.Figure`, not shown), values in ``units``
    (default the machine file's)."""
    import matplotlib

    matplotlib.use("Agg", force=False)
    from matplotlib.figure import Figure

    from camsim.figures.style import _STYLE, displayed, shown

    p = result.problem
    display = units if units is not None else getattr(getattr(p, "base", None), "display_units", None)
    goal = [displayed(g.text, g.unit, display) for g in p.goals]
    s_unit, s_scale = shown("rad/s", display)
    senses = [g.sense for g in p.goals]
    path, responses = _responses(result)
    n = 3 if responses else 2
    with matplotlib.rc_context(_STYLE):
        fig = Figure(figsize=(4.2 * n, 3.4), layout="constrained")
        axes = fig.subplots(1, n)
        ax = axes[0]
        k = np.array([c.index for c in result.candidates])
        f0 = np.array([c.objectives[0] for c in result.candidates], dtype=float) * goal[0][1]
        feas = np.array([c.feasible for c in result.candidates], dtype=bool)
        ax.plot(k[~feas], f0[~feas], ".", color="0.7", label="infeasible")
        ax.plot(k[feas], f0[feas], ".", color="C0", label="feasible")
        best, run = [], None
        for c in result.candidates:
            if c.feasible:
                v = c.f(senses)[0]
                run = v if run is None else min(run, v)
            best.append(math.nan if run is None else (run if senses[0] == "min" else -run) * goal[0][1])
        ax.plot(k, best, "-", color="C3", label="best so far")
        ax.set_xlabel("evaluation")
        ax.set_ylabel(goal[0][0])
        ax.set_title("convergence")
        ax.legend(fontsize="small")
        ax = axes[1]
        if result.front:
            scale = np.array([goal[0][1], goal[1][1]])
            allf = np.array([c.objectives for c in result.candidates if c.feasible], dtype=float)
            if allf.size:
                allf = allf[:, :2] * scale
                ax.plot(allf[:, 0], allf[:, 1], ".", color="0.7", label="evaluated")
            fr = np.array([c.objectives for c in result.front], dtype=float)[:, :2] * scale
            ax.plot(fr[:, 0], fr[:, 1], "o-", color="C3", label="Pareto front")
            ax.set_xlabel(goal[0][0])
            ax.set_ylabel(goal[1][0])
            ax.set_title("Pareto front")
            ax.legend(fontsize="small")
        else:
            speeds = [0.0 if s is None else s * s_scale for s in p.speeds]
            if result.initial is not None and result.initial.per_speed:
                ax.plot(speeds, [s["objectives"][0] * goal[0][1] for s in result.initial.per_speed], "s--", color="0.4", label="file")
            if result.best is not None and result.best.per_speed:
                ax.plot(speeds, [s["objectives"][0] * goal[0][1] for s in result.best.per_speed], "o-", color="C3", label="optimum")
            ax.set_xlabel(f"cam speed [{s_unit}]")
            ax.set_ylabel(goal[0][0])
            ax.set_title("objective over the speeds")
            ax.legend(fontsize="small")
        if responses:
            ax = axes[2]
            y_label, y_scale = displayed(path, responses[0][5], display)
            for i, (speed, a_ang, a, b_ang, b, unit) in enumerate(responses):
                label = "" if speed is None else f" {speed * s_scale:.4g} {s_unit}"
                ax.plot(a_ang, np.asarray(a) * y_scale, "--", color=f"C{i % 10}", lw=0.8, label=f"file{label}")
                ax.plot(b_ang, np.asarray(b) * y_scale, "-", color=f"C{i % 10}", lw=1.0, label=f"optimum{label}")
            ax.set_xlabel("cam angle [deg]")
            ax.set_ylabel(y_label)
            ax.set_title("response")
            ax.legend(fontsize="x-small", ncol=2)
    return fig


def save_optimize_plot(result, path: str | os.PathLike[str], dpi: float = 120.0, units=None) -> Path:
    """Write the figure through the output policy (format from the suffix: png, svg, pdf), values in ``units``."""
    from camsim.figures.style import save_figure

    return save_figure(plot_optimize(result, units=units), Path(path), dpi=dpi)
