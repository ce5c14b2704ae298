"""An interrupted fit resumes from its stored evaluations (issue 16: the row store serves fits).

Reference: the same fit run without interruption. The least-squares solver is
deterministic, so the resumed fit asks for the same parameter vectors; the ones finished
before the interruption come from the store (camsim.io.rowstore), bit for bit, and the
result equals the uninterrupted one exactly.
"""

from __future__ import annotations

import numpy as np
import pytest
from machines import OSC_ZETA, OSCILLATOR

from camsim.errors import InputError
from camsim.analyses.fit import fit
from camsim.analyses.fit import solve as fit_solve
from camsim.analyses.fit.measured import write_measured
from camsim.io.rowstore import journal_path_for
from camsim.machine.loader import load_machine_text
from camsim.run.simulation import simulate

PARAMS = ["element.K.stiffness=10:40N/mm", "element.K.damping_ratio=0.01:0.2"]


@pytest.fixture
def data(tmp_path):
    machine = load_machine_text(OSCILLATOR.replace("20 N/mm", "21.5 N/mm").replace(f"damping_ratio = {OSC_ZETA!r}", "damping_ratio = 0.07"))
    run = simulate(machine)
    acc = run.masses["M"]["acceleration"] + np.random.default_rng(8).normal(0, 0.5, run.time.size)
    return write_measured(tmp_path / "osc.csv", run.time, {"masses/M/acceleration": (acc, "m/s^2")})


def test_interrupted_fit_resumes_to_the_same_answer(oscillator, data, tmp_path, monkeypatch):
    whole = fit(oscillator, data, PARAMS)
    store = tmp_path / "fitted.toml.evaluations.h5"
    real_runs = fit_solve.Evaluator.runs
    calls = {"n": 0}

    def interrupted(self, points):
        calls["n"] += 1
        if calls["n"] == 4:
            raise KeyboardInterrupt
        return real_runs(self, points)

    monkeypatch.setattr(fit_solve.Evaluator, "runs", interrupted)
    with pytest.raises(KeyboardInterrupt):
        fit(oscillator, data, PARAMS, evaluations=store)
    monkeypatch.setattr(fit_solve.Evaluator, "runs", real_runs)
    assert journal_path_for(store).exists()
    with pytest.raises(InputError, match="--resume"):
        fit(oscillator, data, PARAMS, evaluations=store)  # not silently restarted
    resumed = fit(oscillator, data, PARAMS, evaluations=store, resume=True)
    assert np.array_equal(resumed.values, whole.values)
    assert np.array_equal(resumed.ci95, whole.ci95)
    assert resumed.n_evaluations < whole.n_evaluations  # the stored ones were not simulated again
    assert not journal_path_for(store).exists() and not store.exists()  # completed: removed


def test_resume_of_another_fit_is_refused(oscillator, data, tmp_path, monkeypatch):
    store = tmp_path / "e.h5"
    real_runs = fit_solve.Evaluator.runs

    def stop(self, points):
        raise KeyboardInterrupt

    monkeypatch.setattr(fit_solve.Evaluator, "runs", stop)
    with pytest.raises(KeyboardInterrupt):
        fit(oscillator, data, PARAMS, evaluations=store)
    monkeypatch.setattr(fit_solve.Evaluator, "runs", real_runs)
    with pytest.raises(InputError, match="parameters"):
        fit(oscillator, data, PARAMS[:1], evaluations=store, resume=True)
