"""Hypothesis profiles of the invariant suite (tests/invariants/, docs/validation.md).

``camsim-invariants-dev`` runs in the default ``pytest`` (2 machines per invariant);
``camsim-invariants-ci`` in CI (``CI=true``, as ``.ci/run`` sets it: 5 per invariant, about
three minutes of one core, so that ``.ci/run`` stays under 15 minutes on two cores: 16 took
nine); ``camsim-invariants-full`` before a release (``CAMSIM_FULL=1``: 16 per invariant).
All are derandomized: the same machines on every run, so a failure reproduces.
``CAMSIM_INVARIANTS=dev|ci|full`` picks one explicitly.

Shrinking is off (each example is a full simulation; shrinking a failure could take many
minutes): set ``CAMSIM_INVARIANTS_SHRINK=1`` to let hypothesis reduce a failing machine.
The tests use the profile through ``settings(settings.get_profile(PROFILE))``.
"""

from __future__ import annotations

import os

from hypothesis import HealthCheck, Phase, settings

_ci = os.environ.get("CI", "").lower() in ("1", "true", "yes") or os.environ.get("CAMSIM_SLOW") == "1"
_full = os.environ.get("CAMSIM_FULL") == "1"
_choice = os.environ.get("CAMSIM_INVARIANTS", "full" if _full else "ci" if _ci else "dev")
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
settings.register_profile("camsim-invariants-ci", max_examples=5, **_common)
settings.register_profile("camsim-invariants-full", max_examples=16, **_common)
settings.register_profile("camsim-invariants", settings.get_profile(f"camsim-invariants-{_choice}"))
