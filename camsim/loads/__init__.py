"""Process loads (``[[load]]``, spec §10): external forces on masses, as inputs of the engine.

``description`` (the SI dataclasses the loader builds), ``programs`` (a load's force and its
exact time derivatives: constant, segment program or table over the cam angle, table over
time, sine) and ``inputs`` (the cam input with one channel group per load after it).
"""

from camsim.loads.description import KINDS, Load, LoadTable, Sine

__all__ = ["KINDS", "Load", "LoadTable", "Sine"]
