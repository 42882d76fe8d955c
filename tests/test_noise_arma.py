"""The ARMA family of the diagnosis's noise models (:mod:`stictionbench.diagnosis.noise`):
estimates against statsmodels' exact likelihood, the whitening and k-step filters of a
model with an MA part, the root reflection, and the family reaching ``diagnose``."""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
from scipy.signal import freqz, lfilter

from stictionbench.diagnosis import diagnose
from stictionbench.diagnosis.noise import (
    FAMILIES,
    NoiseModel,
    fit_noise_model,
    invertible,
)

sys.path.insert(0, str(Path(__file__).resolve().parent))

from fopdt_record import fopdt_record  # noqa: E402


def _arima111(seed: int, n: int = 2000, load: float = 0.06) -> np.ndarray:
    """A random-walk load through a first-order lag plus white noise: an ARIMA(1,1,1)
    output error whose MA root nears the unit circle (the diagnosis's typical residual)."""
    rng = np.random.default_rng(seed)
    drift = np.cumsum(load * rng.normal(size=n))
    return lfilter([0.1], [1.0, -0.9], drift) + rng.normal(size=n)


@pytest.mark.parametrize("seed", (0, 1, 2))
def test_the_arma_estimate_is_statsmodels_exact_likelihood_one(seed):
    from statsmodels.tsa.arima.model import ARIMA

    y = _arima111(seed)
    nm = fit_noise_model(y, family="arma")
    assert nm.ma_order >= 1
    x = np.diff(y) - np.mean(np.diff(y))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ref = ARIMA(x, order=(nm.order, 0, nm.ma_order), trend="n").fit()
    p = nm.order
    assert -nm.ar[1:] == pytest.approx(ref.params[:p], abs=0.03)
    assert nm.ma[1:] == pytest.approx(ref.params[p:p + nm.ma_order], abs=0.03)
    assert nm.sigma2 == pytest.approx(ref.params[-1], rel=0.03)
    # and it beats the AR model on the criterion both are scored by
    ar = fit_noise_model(y)
    assert ar.ma_order == 0 and nm.to_dict()["family"] in ("ARMA", "ARIMA")


def test_the_ar_family_is_the_default_and_unchanged():
    y = _arima111(3)
    a, b = fit_noise_model(y), fit_noise_model(y, family="ar")
    assert np.array_equal(a.ar, b.ar) and a.integrated == b.integrated
    assert a.ma_order == 0 and a.to_dict()["ma"] == []
    with pytest.raises(ValueError, match="noise family"):
        fit_noise_model(y, family="arx")
    assert FAMILIES == ("ar", "arma")


def test_a_pure_autoregression_keeps_a_short_model():
    rng = np.random.default_rng(4)
    e = rng.normal(size=3000)
    y = lfilter([1.0], [1.0, -1.2, 0.5], e)
    nm = fit_noise_model(y, family="arma", allow_integrated=False)
    # whatever was chosen predicts as well as the truth
    assert nm.sigma2 == pytest.approx(1.0, rel=0.08)
    assert nm.order + nm.ma_order <= 4


def test_whitening_an_arma_series_with_its_model_returns_the_innovations():
    rng = np.random.default_rng(5)
    e = rng.normal(size=500)
    a, c = np.array([1.0, -0.7]), np.array([1.0, -0.5])
    y = lfilter(c, a, e)
    nm = NoiseModel(a, False, 1.0, 0.0, c)
    assert np.allclose(nm.whiten(y), e)
    # column by column for a matrix
    assert np.allclose(nm.whiten(np.column_stack([y, 2 * y])), np.column_stack([e, 2 * e]))
    # one step ahead is the innovation; far ahead the output error itself
    assert np.allclose(nm.kstep(y, 1), e)
    assert np.allclose(nm.kstep(y, 400)[:300], y[:300])
    # integrated: the difference is whitened
    yi = np.cumsum(y)
    ni = NoiseModel(a, True, 1.0, 0.0, c)
    assert np.allclose(ni.whiten(yi), e)
    assert ni.to_dict()["family"] == "ARIMA" and nm.to_dict()["family"] == "ARMA"


def test_reflecting_a_root_keeps_the_spectrum_shape_and_makes_it_invertible():
    c = np.array([1.0, -2.5])                       # root at 2.5: not invertible
    ci = invertible(c)
    assert np.all(np.abs(np.roots(ci)) < 1)
    _, h0 = freqz(c, worN=64)
    _, h1 = freqz(ci, worN=64)
    ratio = np.abs(h0) ** 2 / np.abs(h1) ** 2
    assert np.allclose(ratio, ratio[0])             # the same shape, up to a scale
    ok = np.array([1.0, -0.4, 0.1])
    assert np.array_equal(invertible(ok), ok)
    assert np.array_equal(invertible(np.ones(1)), np.ones(1))


def test_diagnose_fits_the_family_it_is_asked_for():
    rec, model = fopdt_record(load=0.02)
    d = diagnose(rec, model, detectability=False, noise_family="arma")
    nm = d.to_json()["noise_model"]
    assert {"ma_order", "ma", "ar_order", "family"} <= set(nm)
    assert len(nm["ma"]) == nm["ma_order"]
    d0 = diagnose(rec, model, detectability=False)
    assert d0.to_json()["noise_model"]["ma_order"] == 0
    with pytest.raises(ValueError, match="noise_family"):
        diagnose(rec, model, noise_family="garch")


def test_the_tests_family_defaults_to_the_fits_and_is_checked():
    from stictionbench.diagnosis.diagnose import compare

    rec, model = fopdt_record(load=0.02)
    both = compare(rec, model, noise_family="arma")
    assert (both.noise_family, both.test_noise_family) == ("arma", "arma")
    tests = compare(rec, model, test_noise_family="arma")
    assert (tests.noise_family, tests.test_noise_family) == ("ar", "arma")
    with pytest.raises(ValueError, match="test_noise_family"):
        diagnose(rec, model, test_noise_family="ma")


def test_the_command_takes_the_tests_family(tmp_path, capsys):
    import json

    from fopdt_record import write_files

    from stictionbench.cli import main

    csv, model = write_files(fopdt_record(load=0.02)[0], tmp_path)
    out = tmp_path / "d.json"
    assert main(["diagnose", str(csv), "--model", str(model), "--json", str(out),
                 "--test-noise-family", "arma"]) == 0
    details = json.loads(out.read_text())["details"]
    assert (details["noise_family"], details["test_noise_family"]) == ("ar", "arma")
    capsys.readouterr()
    bad = tmp_path / "bad.json"
    assert main(["diagnose", str(csv), "--json", str(bad), "--test-noise-family",
                 "garch"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--test-noise-family" in err[0] and not bad.exists()
