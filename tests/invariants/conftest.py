"""Hypothesis profiles of the invariant suite (tests/invariants/, docs/validation.md).

``camsim-invariants-dev`` runs in the default ``pytest`` (a few machines per invariant,
the whole suite well under 30 s); ``camsim-invariants-ci`` in CI (``CI=true``, as
``.ci/run`` sets it; about three minutes). Both are derandomized: the same machines on
every run, so a failure reproduces. ``CAMSIM_INVARIANTS=dev|ci`` picks one explicitly.

Shrinking is off (each example is a full simulation; shrinking a failure could take many
minutes): set ``CAMSIM_INVARIANTS_SHRINK=1`` to let hypothesis reduce a failing machine.
The tests use the profile through ``settings(settings.get_profile(PROFILE))``.
"""

from __future__ import annotations

import os

from hypothesis import HealthCheck, Phase, settings

_ci = os.environ.get("CI", "").lower() in ("1", "true", "yes") or os.environ.get("CAMSIM_SLOW") == "1"
_choice = os.environ.get("CAMSIM_INVARIANTS", "ci" if _ci else "dev")
_phases = (Phase.explicit, Phase.reuse, Phase.generate, Phase.target)
if os.environ.get("CAMSIM_INVARIANTS_SHRINK") == "1":
    _phases = (*_phases, Phase.shrink)

_common = dict(
    deadline=None,
    derandomize=True,
    database=None,
    print_blob=True,
    phases=_phases,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.filter_too_much],
)
#: Examples per invariant test (the tests scale it: cheap invariants run more).
settings.register_profile("camsim-invariants-dev", max_examples=2, **_common)
settings.register_profile("camsim-invariants-ci", max_examples=16, **_common)
settings.register_profile("camsim-invariants", settings.get_profile(f"camsim-invariants-{_choice}"))
