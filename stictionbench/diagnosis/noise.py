"""Noise models of the output error and Ljung's residual tests.

Every hypothesis of the diagnosis is a deterministic part (the physics) plus a noise model
``H(q)`` on its output error: ``y = G(u; θ) + H(q)e`` with ``e`` white. The predictor's
one-step errors are the *innovations* ``ε = H(q)⁻¹(y − G(u; θ))`` (Ljung, *System
Identification*, 2nd ed. 1999, ch. 7.2 and 16.6). Here ``H⁻¹ = A(q)·(1 − q⁻¹)^d / C(q)``
with ``A`` an autoregressive polynomial and ``C`` a moving-average one, with an integrated
option (``d = 1``) for a load that drifts like a random walk.

- family ``"ar"`` (the shipped default): ``C = 1``, an AR model of the output error. The
  order ``p`` and ``d`` are chosen by BIC (Yule–Walker by
  ``statsmodels.tsa.stattools.levinson_durbin``, on the residual and on its first
  difference, the two likelihoods being of the same data since differencing has unit
  Jacobian).
- family ``"arma"``: that AR model and the ARMA(p, q) models of :data:`ARMA_ORDERS` at
  ``d = 0`` and ``d = 1``, the one of lowest BIC on the same conditional one-step errors
  (:func:`_css_bic`). Each ARMA is started from statsmodels' Hannan–Rissanen estimate
  (``statsmodels.tsa.arima.estimators.hannan_rissanen``) and refined by the
  prediction-error method, the sum of squared one-step errors minimised by
  ``scipy.optimize.least_squares`` (Ljung 1999, ch. 7.2; the conditional least squares of
  Box & Jenkins), with ``C`` reflected inside the unit circle where the fit leaves it
  outside (the same spectrum, an invertible predictor). statsmodels' exact state-space
  likelihood (``ARIMA.fit``) is the reference the tests compare against; it takes about
  0.2 s per model, and a diagnosis fits five to nine noise models of eight candidates
  each. ``reports/concealed/noise_model_family.md`` measured that an MA part makes the
  healthy loops' innovations whiter; ``reports/concealed/arma_diagnosis.md`` that in the
  diagnosis it also calls more healthy loops faulty (fresh sets 3 → 8 of 48), so it is
  not the default.

Tests on innovations (Ljung ch. 16.6): whiteness by the Ljung–Box portmanteau
(``statsmodels.stats.diagnostic.acorr_ljungbox``) and independence from past inputs by
the cross-correlation statistic ``N·Σ r̂²_εu(τ)`` (χ² with ``M`` degrees of freedom) with
the input pre-whitened by the same filter.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.signal import lfilter
from scipy.stats import chi2

#: largest AR order of a noise model
MAX_ORDER = 12
#: the ARMA orders ``(p, q)`` family ``"arma"`` tries beside the AR model (those of
#: ``experiments/noise_model_family.py``, fixed before it ran)
ARMA_ORDERS = ((1, 1), (2, 1), (1, 2), (2, 2))
#: the noise-model families of :func:`fit_noise_model`
FAMILIES = ("ar", "arma")


@dataclass(frozen=True)
class NoiseModel:
    """``H(q)⁻¹ = A(q)(1 − q⁻¹)^d / C(q)``: ``ar`` holds ``[1, a₁, …, a_p]``, ``ma``
    ``[1, c₁, …, c_q]`` (``[1]``: an AR model), every root of ``C`` inside the unit
    circle."""

    ar: np.ndarray
    integrated: bool
    sigma2: float
    bic: float
    ma: np.ndarray = field(default_factory=lambda: np.ones(1))

    @property
    def order(self) -> int:
        return int(self.ar.size - 1)

    @property
    def ma_order(self) -> int:
        return int(self.ma.size - 1)

    def inverse(self) -> np.ndarray:
        """The numerator ``A(q)(1 − q⁻¹)^d`` of the whitening filter, coefficients in
        ``q⁻¹`` (the whole filter for an AR model)."""
        return np.convolve(self.ar, [1.0, -1.0]) if self.integrated else self.ar

    def whiten(self, x: np.ndarray) -> np.ndarray:
        """Innovations of ``x`` (applied along the first axis, zero initial state)."""
        b = self.inverse()
        if self.ma.size > 1:
            return lfilter(b, self.ma, np.asarray(x, float), axis=0)
        if b.size == 1:
            return x * b[0]
        return causal_fir(b, x)

    def kstep(self, x: np.ndarray, k: int) -> np.ndarray:
        """``k``-step-ahead prediction errors of ``x`` under this noise model:
        ``F_k(q)·H(q)⁻¹·x`` with ``F_k`` the first ``k`` impulse-response coefficients of
        ``H`` (Ljung 1999, eq. 3.31). ``k = 1`` gives the innovations; a large ``k`` tends
        to the output error itself. A mismatch slower than the noise model's memory is
        predicted away one step ahead but not ``k`` steps ahead."""
        # beyond the record the k-step error is the output error itself
        k = max(1, int(min(k, max(x.size, 1))))
        imp = np.zeros(k)
        imp[0] = 1.0
        f = lfilter(self.ma, self.inverse(), imp)
        return causal_fir(f, self.whiten(x))

    def to_dict(self) -> dict[str, Any]:
        family = {(False, False): "AR", (True, False): "ARI", (False, True): "ARMA",
                  (True, True): "ARIMA"}[(bool(self.integrated), self.ma.size > 1)]
        return {"family": family, "ar_order": self.order,
                "integrated": bool(self.integrated), "ar": [float(a) for a in self.ar[1:]],
                "ma_order": self.ma_order, "ma": [float(c) for c in self.ma[1:]],
                "innovation_variance": float(self.sigma2)}


def causal_fir(b: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``lfilter(b, [1], x, axis=0)`` from rest, column by column with ``np.convolve``
    (what ``lfilter`` does for an FIR filter, without its per-call ``apply_along_axis``
    overhead, which dominated the whitening of small regressor matrices)."""
    x = np.asarray(x, dtype=float)
    n = x.shape[0]
    if x.ndim == 1:
        return np.convolve(x, b)[:n]
    out = np.empty(x.shape)
    for j in range(x.shape[1]):
        out[:, j] = np.convolve(x[:, j], b)[:n]
    return out


WHITE = NoiseModel(np.ones(1), False, math.nan, math.nan)


def _ar_fit(x: np.ndarray, max_order: int) -> tuple[np.ndarray, float, float]:
    """AR polynomial ``[1, −φ₁, …]``, innovation variance and BIC of ``x``: Yule–Walker
    estimates of every order up to ``max_order`` by the Levinson–Durbin recursion
    (``statsmodels.tsa.stattools.levinson_durbin``), the order by BIC."""
    from statsmodels.tsa.stattools import acovf, levinson_durbin

    x = np.asarray(x, float) - float(np.mean(x))
    n = x.size
    acov = acovf(x, fft=True, nlag=max_order)
    if acov[0] <= 0:
        return np.ones(1), 0.0, -math.inf
    _, _, _, sig, phis = levinson_durbin(acov, nlags=max_order, isacov=True)
    sig = np.asarray(sig, float).copy()
    sig[0] = acov[0]  # statsmodels leaves the order-0 entry at zero
    sig = np.maximum(sig, 1e-300)
    bic = n * np.log(sig) + np.arange(sig.size) * math.log(n)
    p = int(np.argmin(bic))
    if p == 0:
        return np.ones(1), float(sig[0]), float(bic[0])
    phi = np.asarray(phis, float)[1: p + 1, p]
    return np.r_[1.0, -phi], float(sig[p]), float(bic[p])


def invertible(c: np.ndarray) -> np.ndarray:
    """``c = [1, c₁, …]`` with every root outside the unit circle reflected inside
    (``z → 1/z̄``) and the gain kept: the same spectrum ``|C|²`` up to a scale, whose
    inverse filter is stable (Box & Jenkins; Ljung 1999, ch. 4.2)."""
    c = np.asarray(c, float)
    if c.size == 1:
        return np.ones(1)
    roots = np.roots(c)
    out = np.abs(roots) > 1.0
    if not out.any():
        return c
    roots[out] = 1.0 / np.conj(roots[out])
    roots = np.where(np.abs(roots) > 0.999, roots * 0.999 / np.abs(roots), roots)
    return np.real(np.poly(roots))


def _innovations(x: np.ndarray, a: np.ndarray, c: np.ndarray) -> np.ndarray:
    with np.errstate(over="ignore", invalid="ignore"):
        e = lfilter(a, c, x)
    return np.nan_to_num(e, nan=1e150, posinf=1e150, neginf=-1e150)


def _css_bic(x: np.ndarray, a: np.ndarray, c: np.ndarray) -> tuple[float, float]:
    """Innovation variance and BIC of ``x`` (zero mean) under ``A/C``: the conditional
    one-step errors from rest with the first :data:`MAX_ORDER` left out, the same rows
    for every candidate, ``n ln σ² + (p + q) ln n``."""
    e = _innovations(x, a, c)[MAX_ORDER:]
    n = e.size
    s2 = max(float(np.mean(e * e)), 1e-300)
    return s2, n * math.log(s2) + (a.size + c.size - 2) * math.log(n)


def _shifted(x: np.ndarray, k: int) -> np.ndarray:
    return np.r_[np.zeros(k), x[: x.size - k]]


def _arma_fit(x: np.ndarray, p: int, q: int) -> tuple[np.ndarray, np.ndarray]:
    """``A = [1, −φ…]`` and invertible ``C = [1, θ…]`` of an ARMA(p, q) of ``x`` (zero
    mean): Hannan–Rissanen's start (statsmodels; its long AR of order
    :data:`MAX_ORDER`, not bias-corrected), then the one-step errors' sum of squares
    minimised by ``scipy.optimize.least_squares`` with the prediction-error gradient
    ``∂ε/∂aᵢ = q⁻ⁱx/C``, ``∂ε/∂cⱼ = −q⁻ʲε/C`` (Ljung 1999, ch. 10.3)."""
    import warnings

    from scipy.optimize import least_squares
    from statsmodels.tsa.arima.estimators.hannan_rissanen import hannan_rissanen

    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            hr, _ = hannan_rissanen(x, ar_order=p, ma_order=q, demean=False,
                                    initial_ar_order=MAX_ORDER, unbiased=False)
        x0 = np.r_[-np.asarray(hr.ar_params, float), invertible(np.r_[1.0, hr.ma_params])[1:]]
    except (ValueError, np.linalg.LinAlgError):
        x0 = np.full(p + q, np.nan)   # no start from Hannan-Rissanen: white noise instead
    if not np.all(np.isfinite(x0)):
        x0 = np.zeros(p + q)
    skip = MAX_ORDER

    def resid(th: np.ndarray) -> np.ndarray:
        return _innovations(x, np.r_[1.0, th[:p]], np.r_[1.0, th[p:]])[skip:]

    def jac(th: np.ndarray) -> np.ndarray:
        c = np.r_[1.0, th[p:]]
        e = _innovations(x, np.r_[1.0, th[:p]], c)
        u = _innovations(x, np.ones(1), c)
        w = _innovations(e, np.ones(1), c)
        cols = [_shifted(u, i) for i in range(1, p + 1)]
        cols += [-_shifted(w, j) for j in range(1, q + 1)]
        return np.column_stack(cols)[skip:]

    sol = least_squares(resid, x0, jac=jac, method="lm", x_scale="jac",
                        max_nfev=50 * (p + q))
    th = sol.x if np.all(np.isfinite(sol.x)) else x0
    return np.r_[1.0, th[:p]], invertible(np.r_[1.0, th[p:]])


def fit_noise_model(r: np.ndarray, max_order: int = MAX_ORDER,
                    allow_integrated: bool = True, family: str = "ar") -> NoiseModel:
    """Noise model of an output error ``r`` chosen by BIC (see the module docstring).

    Parameters
    ----------
    r : ndarray
        Output error of a deterministic model (training samples, in time order).
    max_order : int
        Largest AR order tried.
    allow_integrated : bool
        Also try the models of the first difference (a random-walk load).
    family : {"ar", "arma"}
        ``"ar"``: AR or integrated AR of order up to ``max_order`` (Yule–Walker, BIC);
        ``"arma"``: that model and the ARMA / ARIMA models of :data:`ARMA_ORDERS`, the
        one of lowest BIC on the same one-step errors.

    References
    ----------
    Ljung, *System Identification* (1999), ch. 7.2 and 16.6; Box & Jenkins, *Time
    Series Analysis* (1976), ch. 7; Hannan & Rissanen, *Biometrika* 69 (1982).
    """
    if family not in FAMILIES:
        raise ValueError(f"noise family must be one of {FAMILIES}, got {family!r}")
    r = np.asarray(r, float)
    max_order = int(max(1, min(max_order, r.size // 20)))
    a0, s0, b0 = _ar_fit(r[1:], max_order)
    best = NoiseModel(a0, False, s0, b0)
    if allow_integrated:
        a1, s1, b1 = _ar_fit(np.diff(r), max_order)
        if b1 < b0:
            best = NoiseModel(a1, True, s1, b1)
    if family == "ar" or r.size < 20 * MAX_ORDER:
        return best
    series = {False: r[1:] - float(np.mean(r[1:]))}
    if allow_integrated:
        d = np.diff(r)
        series[True] = d - float(np.mean(d))
    s2, bic = _css_bic(series[best.integrated], best.ar, np.ones(1))
    best = NoiseModel(best.ar, best.integrated, s2, bic)
    for integrated, x in series.items():
        for p, q in ARMA_ORDERS:
            fitted = _arma_fit(x, p, q)
            s2, bic = _css_bic(x, *fitted)
            if bic < best.bic:
                best = NoiseModel(fitted[0], integrated, s2, bic, fitted[1])
    return best


def ljung_box(e: np.ndarray, lags: int = 20) -> dict[str, float]:
    """Ljung–Box whiteness test of innovations: ``Q = N(N+2) Σ_{k≤h} r̂ₖ²/(N−k)`` against
    χ²(``h``) (Ljung & Box, *Biometrika* 65, 1978), ``h = min(lags, N/5)``.

    The sample autocorrelations ``r̂ₖ`` are statsmodels' ``acf`` computed by FFT: the
    statistic of statsmodels' ``acorr_ljungbox``, which correlates directly (``O(N²)``:
    0.9 s at 100 000 samples, 3.7 s at 200 000 and 35 s at 600 000 — a week at 1 s —
    against 0.02, 0.04 and 0.2 s here).
    """
    from statsmodels.tsa.stattools import acf

    x = np.asarray(e, float)
    n = x.size
    lags = int(max(1, min(lags, n // 5)))
    r = acf(x, nlags=lags, fft=True)[1:]
    stat = float(n * (n + 2) * np.sum(r * r / (n - np.arange(1, lags + 1))))
    return {"statistic": stat, "p_value": float(chi2.sf(stat, lags)), "lags": lags}


def input_independence(e: np.ndarray, u: np.ndarray, lags: int = 20) -> dict[str, float]:
    """Ljung's test that innovations ``e`` are uncorrelated with past inputs ``u`` at
    lags ``1 … lags`` (``u`` leading): ``N·Σ r̂²`` against χ²(``lags``).

    ``u`` is pre-whitened by its own AR model (BIC order), so that the correlations at
    different lags are independent under the null (with a coloured input they are not,
    and the statistic is not χ²). Lag 0 is left out: in closed loop the OP recorded at
    a sample has already reacted to that sample's PV, so it depends on the current
    innovation even when the model is right (Ljung, *System Identification*, 1999,
    §16.6). Past inputs do not, so a correlation there is a model error.
    """
    e = np.asarray(e, float) - float(np.mean(e))
    u = np.asarray(u, float)
    if u.size > 40 and np.ptp(u) > 0:
        u = fit_noise_model(u - float(np.mean(u)), allow_integrated=False).whiten(
            u - float(np.mean(u)))
    u = u - float(np.mean(u))
    n = e.size
    den = math.sqrt(float(np.dot(e, e)) * float(np.dot(u, u)))
    if den <= 0 or n <= lags + 2:
        return {"statistic": 0.0, "p_value": 1.0, "lags": int(lags)}
    r = np.array([float(np.dot(e[k:], u[: n - k])) for k in range(1, lags + 1)]) / den
    stat = float(n * np.sum(r * r))
    return {"statistic": stat, "p_value": float(chi2.sf(stat, lags)), "lags": int(lags)}


#: largest lag either way of :func:`series_independence` (a process dead time of up to this
#: many samples in a record with no feedback is still seen)
INDEPENDENCE_LAGS = 50


def series_independence(y: np.ndarray, u: np.ndarray, lags: int = INDEPENDENCE_LAGS
                        ) -> dict[str, float]:
    """Haugh's test that two series are independent: each pre-whitened by its own noise
    model (:func:`fit_noise_model`, integrated where BIC says so), the residuals'
    cross-correlations ``r̂(k)`` at lags ``−M … M`` summed as
    ``S* = N² Σ r̂(k)² / (N − |k|)`` against χ²(2M + 1).

    Any closed loop makes OP and PV dependent both ways (the process from OP to PV, the
    controller from PV to OP), so independence that the data cannot reject means the
    recording's OP does not drive its PV: a tag of another loop, or a loop with no
    dynamics in the record. ``M = min(lags, N/10)``.

    The same sum over the lags ``1 … M`` alone (``u`` leads ``y``) against χ²(M) tests
    one direction of the dependence (Pierce & Haugh): in a closed loop whose OP (``u``)
    does not reach its PV (``y``) — a valve at rest, a controller in manual — PV still
    drives OP through the controller, at lags ``≤ 0``, and nothing leads the other way.
    Nor, in a regulatory loop whose valve does move PV, when nothing but the controller's
    linear answer moves OP: OP is then a function of PV's past and adds nothing to PV's
    prediction (Caines & Chan 1975), so the one-sided test sees OP's effect only where OP
    is excited beyond it (set-point changes, a nonlinearity, a dither), and only with each
    series fully whitened (``reports/diagnose/drive_check_regulation.md``).

    Returns
    -------
    dict
        ``statistic``, ``p_value``, ``lags`` (M), ``peak_lag``, the lag of the largest
        ``|r̂(k)|`` (positive: ``u`` leads), and ``p_u_leads`` / ``p_y_leads``, the tests
        over the lags ``1 … M`` / ``−M … −1`` alone.

    References
    ----------
    L. D. Haugh, "Checking the independence of two covariance-stationary time series: a
    univariate residual cross-correlation approach", *JASA* 71 (1976) 378–385; Box,
    Jenkins & Reinsel, *Time Series Analysis* (4th ed., 2008), §11.1; D. A. Pierce and
    L. D. Haugh, "Causality in temporal systems", *J. Econometrics* 5 (1977) 265–293;
    P. E. Caines and C. W. Chan, "Feedback between stationary stochastic processes",
    *IEEE Trans. Automatic Control* 20 (1975) 498–508.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> a, b = rng.normal(size=2000), rng.normal(size=2000)
    >>> series_independence(a, b)["p_value"] > 0.05
    True
    >>> y = a[5:] + 0.3 * b[:-5]  # y(t) = a(t) + 0.3 b(t − 5): b leads by five samples
    >>> r = series_independence(y, b[5:])
    >>> bool(r["p_value"] < 1e-6), r["peak_lag"], bool(r["p_u_leads"] < 1e-6)
    (True, 5, True)
    >>> bool(series_independence(b[5:], y)["p_u_leads"] > 1e-3)  # y does not lead b
    True
    """
    from scipy.signal import correlate

    def whitened(x: np.ndarray) -> np.ndarray:
        x = np.asarray(x, float) - float(np.mean(x))
        m = fit_noise_model(x)
        e = m.whiten(x)[m.order + 1 + int(m.integrated):]
        return e - float(np.mean(e))

    a, b = whitened(y), whitened(u)
    n = min(a.size, b.size)
    a, b = a[a.size - n:], b[b.size - n:]
    m = int(max(1, min(lags, n // 10)))
    den = math.sqrt(float(np.dot(a, a)) * float(np.dot(b, b)))
    if den <= 0 or n <= 2 * m + 2:
        return {"statistic": 0.0, "p_value": 1.0, "lags": m, "peak_lag": 0,
                "p_u_leads": 1.0, "p_y_leads": 1.0}
    # correlate(a, b)[n - 1 + j] = Σ a[i + j]·b[i]: a (y) later than b (u) by j, u leads
    c = correlate(a, b, mode="full", method="fft")[n - 1 - m: n + m] / den
    k = np.arange(-m, m + 1)
    terms = n * n * c * c / (n - np.abs(k))
    stat = float(np.sum(terms))
    return {"statistic": stat, "p_value": float(chi2.sf(stat, 2 * m + 1)), "lags": m,
            "peak_lag": int(k[np.argmax(np.abs(c))]),
            "p_u_leads": float(chi2.sf(float(np.sum(terms[k > 0])), m)),
            "p_y_leads": float(chi2.sf(float(np.sum(terms[k < 0])), m))}


def lr_test(v_null: float, v_alt: float, n: int, df: int) -> dict[str, float]:
    """Likelihood-ratio test of nested Gaussian predictors from their innovation
    variances: ``N·ln(V₀/V₁)`` against χ²(df)."""
    stat = float(n * math.log(max(v_null, 1e-300) / max(v_alt, 1e-300)))
    return {"statistic": stat, "p_value": float(chi2.sf(max(stat, 0.0), df)), "df": int(df)}
