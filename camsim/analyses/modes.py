"""Natural frequencies of every branch configuration (thesis §7.2.1)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from camsim.errors import InputError
from camsim.machine.description import Machine
from camsim.model.assembly import Branch, Model

#: More switching combinations than this are not all listed.
MAX_CONFIGURATIONS = 256


@dataclass
class ConfigurationModes:
    """Modes of one combination of branches.

    Attributes
    ----------
    branches : dict
        element name → branch ("joined", "separated", "open", "closed", "stuck", ...).
    frequencies : list of float
        Undamped natural frequencies [Hz], ascending (rigid-body modes are 0).
    damping_ratios : list of float
        ζ of each mode (NaN for rigid-body modes).
    stiffness_ratio : float or None
        Highest over lowest non-zero natural frequency: how far apart the time scales are
        (the thesis calls a system stiff above ~200, non-stiff below ~20).
    nonlinear : bool
        A power-law contact is closed: its stiffness depends on the load; only the linear
        part is listed.
    """

    branches: dict[str, str]
    frequencies: list[float]
    damping_ratios: list[float]
    stiffness_ratio: float | None
    nonlinear: bool = False


def machine_modes(machine: Machine) -> list[ConfigurationModes]:
    """Modes of each configuration the machine's contacts and links can be in."""
    model = Model(machine)
    combos = model.all_branch_combinations()
    if len(combos) > MAX_CONFIGURATIONS:
        raise InputError(f"{machine.source}: {len(combos)} branch configurations; modes lists at most {MAX_CONFIGURATIONS}")
    out = []
    for branches in combos:
        try:
            modes = model.natural_modes(branches)
        except InputError:
            continue  # e.g. rigid contacts that cannot all be closed together
        config = model.configuration(branches)
        freqs = [f for f, _ in modes]
        zetas = [z for _, z in modes]
        nonzero = [f for f in freqs if f > 1e-9]
        ratio = (max(nonzero) / min(nonzero)) if nonzero else None
        names = {model.elements[i].name: b.value for i, b in zip(model.switching, branches)}
        out.append(ConfigurationModes(names, freqs, zetas, ratio, nonlinear=not config.linear))
    return out


#: Rod modes listed by :func:`rod_modes` (the lowest; a long discretisation has many).
ROD_MODES_SHOWN = 8


def rod_modes(machine: Machine) -> list[dict]:
    """Each rod's own axial modes, free at both ends (issue 39), JSON-able, SI.

    ``lumped_hz``: the N-segment chain's natural frequencies (N·c/(π·L))·sin(jπ/2N);
    ``continuum_hz``: the continuous rod's j·c/(2L); ``error``: lumped/continuum − 1 (the
    chain's dispersion: −(jπ/2N)²/6 for j ≪ N); ``damping_ratios``: ζ·ωⱼ/ω₁ of its
    stiffness-proportional damping (0 without ``damping_ratio``); ``highest_hz``: f_N.
    """
    out = []
    for rod in machine.elements:
        if not rod.compound:
            continue
        lumped = rod.chain_frequencies()[1:]
        count = min(len(lumped), ROD_MODES_SHOWN)
        continuum = rod.continuum_frequencies(count)
        zeta = rod.damping.ratio or 0.0
        out.append({
            "rod": rod.name, "segments": rod.segments, "segments_reason": rod.segments_reason,
            "highest_hz": float(lumped[-1]),
            "lumped_hz": [float(f) for f in lumped[:count]],
            "continuum_hz": [float(f) for f in continuum],
            "error": [float(a / b - 1.0) for a, b in zip(lumped[:count], continuum)],
            "damping_ratios": [float(zeta * f / lumped[0]) for f in lumped[:count]],
        })
    return out


def modes_to_dict(modes: list[ConfigurationModes], rods: list[dict] | None = None) -> list[dict]:
    """The configurations as JSON-able dicts; with rods, each carries ``rods`` (:func:`rod_modes`)."""
    out = [
        {
            "branches": m.branches,
            "frequencies_hz": m.frequencies,
            "damping_ratios": [None if math.isnan(z) else z for z in m.damping_ratios],
            "stiffness_ratio": m.stiffness_ratio,
            "nonlinear": m.nonlinear,
        }
        for m in modes
    ]
    if rods:
        for entry in out:
            entry["rods"] = rods
    return out


__all__ = ["Branch", "ConfigurationModes", "machine_modes", "modes_to_dict", "rod_modes"]
