"""Identifiability: parameters that act only through their product are reported.

In tests/fit/machines.py ``PRODUCT`` the cam lifts are follower-arm angles, so the model
axis motion is s = ratio · arm · angle (spec §2): ``cam.ratio`` and ``cam.arm`` change
the cam contact force only through their product. The fit must say so (naming both),
and it must still pin down the product: the truth 0.5 × 0.1 m = 0.05 m within 1e-3
relative (noise 0.5 N on forces of ~100 N).
"""

from __future__ import annotations

import numpy as np
from machines import H, K_TRUE, MASS, OMEGA, P_TRUE

from camsim.analyses.fit import fit
from camsim.analyses.fit.measured import write_measured


def test_product_parameters_are_not_identifiable(product, tmp_path):
    t = np.arange(0, 501) / 1000.0
    s = H / 2 * (1 - np.cos(OMEGA * t))
    a = H / 2 * OMEGA**2 * np.cos(OMEGA * t)
    y = MASS * a + P_TRUE + K_TRUE * s + np.random.default_rng(3).normal(0, 0.5, t.size)
    csv = write_measured(tmp_path / "m.csv", t, {"cam_contact/force": (y, "N")})
    r = fit(product, csv, ["cam.ratio=0.3:0.8:0.45", "cam.arm=50:150:120mm"])
    ratio, arm = r.values
    assert abs(ratio * arm / 0.05 - 1) < 1e-3
    joined = "\n".join(r.warnings)
    assert "not identifiable" in joined
    lines = [w for w in r.warnings if "cam.ratio" in w and "cam.arm" in w]
    assert lines, r.warnings  # one warning names both parameters
    assert abs(r.correlation[0, 1]) > 0.95 or not np.isfinite(r.correlation[0, 1])


def test_a_well_posed_fit_has_no_identifiability_warning(driven, tmp_path):
    t = np.arange(0, 501) / 1000.0
    s = H / 2 * (1 - np.cos(OMEGA * t))
    a = H / 2 * OMEGA**2 * np.cos(OMEGA * t)
    y = MASS * a + P_TRUE + K_TRUE * s + np.random.default_rng(4).normal(0, 0.5, t.size)
    csv = write_measured(tmp_path / "m.csv", t, {"cam_contact/force": (y, "N")})
    r = fit(driven, csv, ["element.K.stiffness=1000:10000", "mass.M.mass=1:3kg"])
    assert r.converged and r.warnings == []
    assert abs(r.values[1] - MASS) < 3 * r.stderr[1]


def test_a_parameter_that_changes_nothing_is_named(driven, tmp_path):
    # the cam displacement of a driven machine does not depend on the spring stiffness
    t = np.arange(0, 501) / 1000.0
    s = H / 2 * (1 - np.cos(OMEGA * t)) + np.random.default_rng(5).normal(0, 1e-5, t.size)
    csv = write_measured(tmp_path / "m.csv", t, {"cam/displacement": (s, "m")})
    r = fit(driven, csv, ["element.K.stiffness=1000:10000"])
    assert any("element.K.stiffness" in w and "does not change the residuals" in w for w in r.warnings), r.warnings
    assert not np.isfinite(r.stderr[0])
