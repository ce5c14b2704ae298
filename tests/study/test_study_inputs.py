"""Parsing of the study's inputs and the sampling transforms (issue 15).

References: unit factors from NIST SP 811 (1 lbf = 0.45359237 kg x 9.80665 m/s^2 = 4.4482216152605 N, 1 in = 0.0254 m);
moments of the truncated normal from Johnson, Kotz & Balakrishnan, *Continuous
Univariate Distributions* vol. 1 (1994), eq. 13.134-13.135; lognormal median and
geometric std by definition (ln X ~ N(ln median, ln GSD)).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from camsim.errors import InputError
from camsim.analyses.study.distributions import parse_dist
from camsim.analyses.study.sampling import apply_copula, correlation_matrix, parse_correlate, to_values, unit_sample

LBF_PER_IN = 0.45359237 * 9.80665 / 0.0254  # [N/m]


def _phi(x):
    return math.exp(-x * x / 2) / math.sqrt(2 * math.pi)


def test_units_after_the_last_number_apply_to_all():
    d = parse_dist("element.K01.stiffness=normal:25.62:2.5lbf/in")
    assert d.params == pytest.approx((25.62 * LBF_PER_IN, 2.5 * LBF_PER_IN), rel=1e-12)
    assert d.unit == "N/m"
    d = parse_dist("element.seat.gap=uniform:0.06in:0.065in")
    assert (d.low, d.high) == pytest.approx((0.06 * 0.0254, 0.065 * 0.0254), rel=1e-12)
    d = parse_dist("cam.speed=normal:120:2rpm")
    assert d.params == pytest.approx((120 * 2 * math.pi / 60, 2 * 2 * math.pi / 60), rel=1e-12)
    d = parse_dist("mass.M1.mass=normal:7.4:0.1")  # bare: SI
    assert d.params == (7.4, 0.1)


def test_symmetric_tolerance_is_a_normal_truncated_at_three_sigma():
    """tol:10:0.3mm: mean 10 mm, sigma 0.1 mm truncated at +-3 sigma (JKB eq. 13.135)."""
    d = parse_dist("element.seat.gap=tol:10:0.3mm")
    assert (d.low, d.high) == pytest.approx((0.0097, 0.0103), rel=1e-12)
    f = d.frozen()
    a = 3.0
    z = math.erf(a / math.sqrt(2))  # Phi(a) - Phi(-a)
    var = 1 - 2 * a * _phi(a) / z
    assert f.mean() == pytest.approx(0.010, rel=1e-12)
    assert f.std() == pytest.approx(1e-4 * math.sqrt(var), rel=1e-9)
    # --tol-sigma 2: sigma = 0.15 mm, truncated at +-2 sigma
    f2 = parse_dist("element.seat.gap=tol:10:0.3mm", tol_sigma=2.0).frozen()
    var2 = 1 - 2 * 2.0 * _phi(2.0) / math.erf(2.0 / math.sqrt(2))
    assert f2.std() == pytest.approx(1.5e-4 * math.sqrt(var2), rel=1e-9)
    x = d.ppf(np.array([1e-12, 0.5, 1 - 1e-12]))
    assert x[0] >= 0.0097 - 1e-15 and x[2] <= 0.0103 + 1e-15 and x[1] == pytest.approx(0.010, rel=1e-12)


def test_asymmetric_tolerance_limits():
    """tol:10:+0.2:-0.1mm: limits 9.9 and 10.2 mm, centred between them, sigma = 0.3/6 mm."""
    d = parse_dist("element.seat.gap=tol:10:+0.2:-0.1mm")
    assert (d.low, d.high) == pytest.approx((0.0099, 0.0102), rel=1e-12)
    assert d.frozen().mean() == pytest.approx(0.01005, rel=1e-12)
    assert d.nominal == pytest.approx(0.010)


def test_lognormal_median_and_gsd():
    d = parse_dist("mass.M1.mass=lognormal:2:1.1kg")
    f = d.frozen()
    assert f.median() == pytest.approx(2.0, rel=1e-12)
    assert f.ppf(0.841344746068543) == pytest.approx(2.0 * 1.1, rel=1e-9)  # one sigma up: median * GSD


def test_truncnormal_support():
    d = parse_dist("element.K01.preload=truncnormal:100:10:90:130N")
    x = d.ppf(np.linspace(1e-9, 1 - 1e-9, 101))
    assert x.min() >= 90 - 1e-9 and x.max() <= 130 + 1e-9


@pytest.mark.parametrize(
    "text, words",
    [
        ("k=gamma:1:2", "unknown distribution 'gamma'"),
        ("k=normal:1:0", "STD must be > 0"),
        ("k=normal:1:-2", "STD must be > 0"),
        ("k=truncnormal:1:1:3:2", "LOW must be below HIGH"),
        ("k=uniform:2:2", "LOW must be below HIGH"),
        ("k=lognormal:2:0.9", "GSD"),
        ("k=lognormal:-2:1.2", "MEDIAN must be > 0"),
        ("k=tol:10:+0.2:+0.1mm", "outside its own tolerance"),
        ("k=tol:10:-0.1:-0.2mm", "outside its own tolerance"),
        ("k=tol:10:0mm", "PLUSMINUS must be > 0"),
        ("k=normal:1", "expected normal:MEAN:STD"),
        ("element.seat.stiffness=normal:1:0.1mm", "does not fit"),
        ("k=normal:1mm:0.1N", "only repeat its unit"),
        ("normal:1:2", "expected KEY=SPEC"),
        ("k=normal:abc:1", "not a number"),
    ],
)
def test_bad_specs_name_the_option(text, words):
    with pytest.raises(InputError) as err:
        parse_dist(text)
    msg = str(err.value)
    assert msg.startswith(f"--dist {text}: ") and words in msg and "\n" not in msg


def test_samples_are_reproducible_and_in_the_unit_cube():
    for method in ("mc", "lhs", "sobol"):
        a, b = unit_sample(64, 3, method, 7), unit_sample(64, 3, method, 7)
        assert np.array_equal(a, b)
        assert not np.array_equal(a, unit_sample(64, 3, method, 8))
        assert a.min() > 0 and a.max() < 1
    warn: list[str] = []
    unit_sample(100, 2, "sobol", 0, warn)
    assert warn and "power of two" in warn[0]
    warn.clear()
    unit_sample(128, 2, "sobol", 0, warn)
    assert not warn


def test_latin_hypercube_is_stratified():
    u = unit_sample(50, 2, "lhs", 1)
    for j in range(2):
        assert sorted(np.floor(u[:, j] * 50).astype(int)) == list(range(50))


def test_gaussian_copula_gives_the_normal_score_correlation():
    """Normal scores of copula-coupled inputs have correlation rho (MC, n = 20000: 4 s.e. = 0.02)."""
    from scipy.stats import norm

    keys = ["a", "b", "c"]
    pairs = [parse_correlate("a,b=0.6", keys), parse_correlate("b,c=-0.3", keys)]
    corr = correlation_matrix(pairs, 3, ["a,b=0.6", "b,c=-0.3"])
    u = apply_copula(unit_sample(20000, 3, "mc", 2), corr)
    r = np.corrcoef(norm.ppf(u).T)
    assert r[0, 1] == pytest.approx(0.6, abs=0.02)
    assert r[1, 2] == pytest.approx(-0.3, abs=0.02)
    assert r[0, 2] == pytest.approx(0.0, abs=0.02)  # a pair not given is uncorrelated
    # marginals stay uniform: a tol input keeps its limits
    d = parse_dist("x=tol:1:0.1")
    x = to_values(u[:, :1], [d])
    assert x.min() >= 0.9 and x.max() <= 1.1


@pytest.mark.parametrize(
    "texts, words",
    [
        (["a,b=1.2"], "strictly between -1 and 1"),
        (["a,z=0.5"], "z is not one of the --dist inputs"),
        (["a,a=0.5"], "itself"),
        (["a-b=0.5"], "expected KEY1,KEY2=RHO"),
        (["a,b=0.9", "b,c=0.9", "a,c=-0.9"], "not positive definite"),
    ],
)
def test_bad_correlations(texts, words):
    keys = ["a", "b", "c"]
    with pytest.raises(InputError) as err:
        pairs = [parse_correlate(t, keys) for t in texts]
        correlation_matrix(pairs, 3, texts)
    assert str(err.value).startswith("--correlate") and words in str(err.value)
