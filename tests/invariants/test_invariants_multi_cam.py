"""Invariants (h) and (a), (b), (c), (g) on several cams on one shaft (see test_invariants.py;
their own file so that the CI profile runs them on a worker of their own)."""

from __future__ import annotations

import pytest
from hypothesis import assume, given, note
from hypothesis import strategies as st

from invariant_tests import PROFILE, RATE_PAIRS, _report, _runs, _safely, _no_worse_than_alone
from invariant_checks import check_located_extremes, check_permutation, check_sample_rate, check_stations, check_streamed, check_warmup, in_order_of, permute_text
from machine_gen import multi_cam_specs, render_multi, render_station


@PROFILE
@given(spec=multi_cam_specs(linear=True))
def test_h_each_station_equals_the_station_alone(spec):
    """(h) Several cams on a rigid shaft: each station = the station alone with its phase.

    Linear stations (springs, links, linear contacts, driven or through a roller): a rigid
    contact's resolution scales its tolerances with every mass of the machine (chatter then
    resolves differently beside another station), and a station alone with a rigid seat held
    stuck under a closing power-law contact can miss the seat's release (found by this
    invariant; the engine's, reported in issue 38's notes)."""
    text = render_multi(spec)
    alone = [render_station(spec, k) for k in range(len(spec.stations))]
    note(f"machine file:\n{text}")
    _report("h-stations", text, check_stations(text, alone, [f"S{k}_" for k in range(len(spec.stations))]))


@PROFILE
@given(spec=multi_cam_specs(stations=2), rates=st.sampled_from(RATE_PAIRS))
def test_a_multi_cam_sample_rate(spec, rates):
    """(a) on several cams: two sample rates, the same events and shared samples (no worse
    than the stations alone)."""
    text = render_multi(spec)
    note(f"machine file:\n{text}\nrates: {rates}")
    assume(_runs(text, spec))
    _no_worse_than_alone("a-multi-cam", spec, text, _safely(check_sample_rate)(text, rates),
                         lambda t: check_sample_rate(t, rates))


@pytest.mark.slow  # the default pytest's 3 minutes: CI runs it
@PROFILE
@given(spec=multi_cam_specs(stations=2))
def test_b_multi_cam_warmup_and_streaming(spec, tmp_path_factory):
    """(b) on several cams: the streamed run bit for bit; the warm-up revolution equals the
    second one (no worse than the stations alone)."""
    text = render_multi(spec)
    note(f"machine file:\n{text}")
    assume(_runs(text, spec))
    _report("b-multi-cam-stream", text, check_streamed(text, tmp_path_factory.mktemp("stream")))
    _no_worse_than_alone("b-multi-cam-warmup", spec, text, _safely(check_warmup)(text), check_warmup)


@PROFILE
@given(spec=multi_cam_specs(stations=2), rates=st.sampled_from(RATE_PAIRS))
def test_g_multi_cam_located_extremes(spec, rates):
    """(g) on several cams: impact peaks and located extremes (each station's cam force among
    them) the same at two sample rates (no worse than the stations alone)."""
    text = render_multi(spec)
    note(f"machine file:\n{text}\nrates: {rates}")
    assume(_runs(text, spec))
    _no_worse_than_alone("g-multi-cam", spec, text, _safely(check_located_extremes)(text, rates),
                         lambda t: check_located_extremes(t, rates))


@pytest.mark.slow  # the default pytest's 3 minutes: CI runs it
@PROFILE
@given(spec=multi_cam_specs(), seed=st.integers(min_value=0, max_value=2**16))
def test_c_multi_cam_file_order(spec, seed):
    """(c) on several cams: shuffled [[cam]], [[mass]] and [[element]] tables change nothing
    (no worse than each station alone with its tables in the same order)."""
    text = render_multi(spec)
    other = permute_text(text, seed)
    note(f"machine file:\n{text}\npermuted (seed {seed}):\n{other}")
    assume(_runs(text, spec))
    _no_worse_than_alone("c-multi-cam", spec, text, _safely(check_permutation)(text, other),
                         lambda t: check_permutation(t, in_order_of(t, other)))
