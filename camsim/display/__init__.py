"""Display units: the one presentation layer of every human-facing value (issue 36).

Inside camsim everything is SI. What a person reads — command tables, summaries, warnings,
report pages, figure axes — is shown in *display units*: by default the units the machine
file was written in, per dimension (a file with forces in lbf and lengths in in shows lbf,
in, in/s, lbf/in), or SI or US customary with ``--units si|us``. JSON and HDF5 stay SI with
their units named.

- :mod:`camsim.display.units`: :class:`DisplayUnits` (dimension → unit, conversion from an SI
  unit text), the fixed ``si`` and ``us`` choices, how derived units follow from base ones;
- :mod:`camsim.display.written`: the ``file`` choice, counted from a machine document and the
  command line;
- :mod:`camsim.display.text`: engineering prefixes (``50 kHz``), SI quantities in messages.

This layer sits under every consumer (figures, reports, analyses, the CLI) and above
:mod:`camsim.units`, the one pint registry it counts written units with.
"""

from camsim.display.text import engineering, in_units, typographic_units
from camsim.display.units import SI, SYSTEMS, US, DisplayUnits, Unit, system_units, typographic
from camsim.display.written import display_units, option_quantities, written_units

__all__ = [
    "SI", "SYSTEMS", "US", "DisplayUnits", "Unit", "display_units", "engineering", "in_units", "option_quantities",
    "system_units", "typographic", "typographic_units", "written_units",
]
