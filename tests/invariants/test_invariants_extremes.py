"""Invariant (g) on single-cam machines: located extremes at two sample rates (see
test_invariants.py; its own file so that the CI profile's largest property runs on its own worker)."""

from __future__ import annotations

from hypothesis import given, note
from hypothesis import strategies as st

from invariant_tests import PROFILE, RATE_PAIRS, _floored, _report
from invariant_checks import check_located_extremes
from machine_gen import machine_specs, render


@PROFILE
@given(spec=machine_specs(), rates=st.sampled_from(RATE_PAIRS))
def test_g_located_extremes_do_not_depend_on_the_sample_rate(spec, rates):
    """(g) Impact peaks (value, instant) and the summary's located extremes: the same at two
    sample rates, 5 to 500 kHz (1e-9 of their scale; numerically integrated laws: their
    trace tolerance)."""
    text = render(spec)
    note(f"machine file:\n{text}\nrates: {rates}")
    _report("g-extremes", text, _floored(check_located_extremes, spec, text, rates, sample_rate=rates[0]))
