"""Apparent stiction from an ellipse fitted to the filtered PV–OP plot.

Choudhury, Shah, Thornhill & Shook (2006) quantify stiction in a loop already found
nonlinear: both signals are band-pass filtered around the loop's oscillation, an
ellipse is fitted to the (OP, PV) cloud, and the *apparent stiction* is the width of the
ellipse along the OP axis through its centre (the OP chord at mean PV). For
``OP = A·sin θ``, ``PV = B·sin(θ − φ)`` that chord is ``2A·sin φ``.

The ellipse is fitted by the direct least-squares method of Fitzgibbon, Pilu & Fisher
(1999) in the numerically stable form of Halíř & Flusser (1998), on standardised
coordinates.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from numbers import Integral, Real
from typing import ClassVar

import numpy as np

from ..errors import InputError
from ..recording import Recording
from ..validation import Band, Constraint, Interval, check_signal
from .base import EstimateResult, Estimator
from .oscillation import acf_oscillation, bandpass, bandpass_gain, dominant_frequency

#: fewest samples accepted
MIN_SAMPLES = 64
#: S3 of the Halíř–Flusser split is inverted; beyond this condition number the
#: cloud is (numerically) a straight line
MAX_CONDITION = 1e12


@dataclass(frozen=True)
class EllipseFit:
    """A fitted ellipse, in the units of the data.

    Attributes
    ----------
    conic : ndarray, shape (6,)
        ``(a, b, c, d, e, f)`` of ``a·u² + b·uv + c·v² + d·u + e·v + f = 0`` in the
        standardised coordinates ``u = (x − mean x)/std x``, ``v = (y − mean y)/std y``,
        scaled to ``4ac − b² = 1``.
    centre : (float, float)
        ``(x0, y0)``.
    axes : (float, float)
        Semi-major and semi-minor axis lengths (data units; meaningful as lengths only
        when x and y share units).
    angle : float
        Angle of the major axis from the x axis, radians in ``(−π/2, π/2]``.
    chord_x : float
        Length of the chord parallel to the x axis through the centre,
        ``2·sqrt(−F0/A)`` with ``A`` the x² coefficient and ``F0`` the conic at the
        centre (equivalently ``2ab/sqrt(a² sin²α + b² cos²α)``).
    axis_ratio : float
        Minor/major axis ratio in standardised coordinates (unit-free; ``tan(φ/2)`` for
        two equal-amplitude sinusoids ``φ`` apart, 0 for a line).
    residual : float
        RMS of ``r − 1``, ``r`` the radius of each point in the frame where the ellipse
        is the unit circle; 0 for points on the ellipse.
    """

    conic: np.ndarray
    centre: tuple[float, float]
    axes: tuple[float, float]
    angle: float
    chord_x: float
    axis_ratio: float
    residual: float

    def points(self, n: int = 200) -> np.ndarray:
        """``n`` points on the ellipse, shape ``(n, 2)`` (x, y), for plotting."""
        t = np.linspace(0.0, 2.0 * np.pi, n)
        a, b = self.axes
        ca, sa = math.cos(self.angle), math.sin(self.angle)
        ex, ey = a * np.cos(t), b * np.sin(t)
        return np.column_stack(
            [self.centre[0] + ca * ex - sa * ey, self.centre[1] + sa * ex + ca * ey]
        )


def fit_ellipse(x: np.ndarray, y: np.ndarray) -> EllipseFit | None:
    """Direct least-squares ellipse fit (Fitzgibbon et al. 1999; Halíř & Flusser 1998).

    Minimises the algebraic distance ``Σ (a·u² + b·uv + c·v² + d·u + e·v + f)²`` subject
    to ``4ac − b² = 1``, which forces an ellipse. Halíř & Flusser split the design
    matrix into its quadratic part ``D1 = [u², uv, v²]`` and linear part
    ``D2 = [u, v, 1]``; with ``S1 = D1ᵀD1``, ``S2 = D1ᵀD2``, ``S3 = D2ᵀD2``,
    ``T = −S3⁻¹S2ᵀ`` and ``M = C1⁻¹(S1 + S2·T)`` (``C1`` the 3×3 constraint matrix), the
    quadratic coefficients are the eigenvector of ``M`` with ``4ac − b² > 0`` and the
    linear ones ``T·(a, b, c)``. Data are standardised first (``u, v``) for conditioning;
    centre, axes and chord are mapped back to data units.

    Parameters
    ----------
    x, y : ndarray
        Point coordinates (same length, at least 6 points).

    Returns
    -------
    EllipseFit or None
        None when the cloud is degenerate: (numerically) a straight line, or no
        eigenvector gives a real ellipse.

    References
    ----------
    A. Fitzgibbon, M. Pilu, R. B. Fisher, "Direct least square fitting of ellipses",
    IEEE Trans. PAMI 21 (1999) 476–480.
    R. Halíř, J. Flusser, "Numerically stable direct least squares fitting of
    ellipses", Proc. WSCG (1998) 125–132.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.linspace(0, 2 * np.pi, 100, endpoint=False)
    >>> fit = fit_ellipse(3 + 2 * np.cos(t), -1 + np.sin(t))
    >>> [round(v, 6) for v in (*fit.centre, *fit.axes, fit.chord_x)]
    [3.0, -1.0, 2.0, 1.0, 4.0]
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    if x.shape != y.shape or x.ndim != 1 or x.size < 6:
        raise InputError("ellipse fit: x and y must be 1-D of equal length >= 6")
    mx, my = float(x.mean()), float(y.mean())
    sx, sy = float(x.std()), float(y.std())
    if sx == 0.0 or sy == 0.0:
        return None
    u, v = (x - mx) / sx, (y - my) / sy
    D1 = np.column_stack([u * u, u * v, v * v])
    D2 = np.column_stack([u, v, np.ones_like(u)])
    S1, S2, S3 = D1.T @ D1, D1.T @ D2, D2.T @ D2
    if np.linalg.cond(S3) > MAX_CONDITION:
        return None
    T = -np.linalg.solve(S3, S2.T)
    M = S1 + S2 @ T
    # C1⁻¹·M with C1 = [[0, 0, 2], [0, -1, 0], [2, 0, 0]]
    M = np.vstack([M[2] / 2.0, -M[1], M[0] / 2.0])
    w, vec = np.linalg.eig(M)
    vec = np.real(vec)
    cond = 4.0 * vec[0] * vec[2] - vec[1] ** 2
    ok = np.flatnonzero(cond > 0)
    if ok.size == 0:
        return None
    # One eigenvector satisfies the constraint in exact arithmetic; with rounding,
    # take the one with the smallest non-negative eigenvalue (smallest algebraic error).
    j = ok[np.argmin(np.abs(np.real(w[ok])))]
    a1 = vec[:, j] / math.sqrt(cond[j])
    if a1[0] + a1[2] < 0:  # eigenvector sign is arbitrary: make the quadratic form positive
        a1 = -a1
    conic = np.concatenate([a1, T @ a1])
    A, B, C, D, E, F = conic
    Q = np.array([[A, B / 2.0], [B / 2.0, C]])
    cu, cv = np.linalg.solve(2.0 * Q, -np.array([D, E]))
    F0 = A * cu * cu + B * cu * cv + C * cv * cv + D * cu + E * cv + F
    lam_std = np.linalg.eigvalsh(Q)
    if not (np.all(lam_std > 0) and F0 < 0):
        return None
    axis_ratio = math.sqrt(lam_std[0] / lam_std[1])
    # Quadratic form in data units: (p − c)ᵀ Q' (p − c) = −F0, Q' = S⁻¹ Q S⁻¹.
    s_inv = np.diag([1.0 / sx, 1.0 / sy])
    Qd = s_inv @ Q @ s_inv
    lam, evec = np.linalg.eigh(Qd)  # ascending: lam[0] belongs to the major axis
    semi = np.sqrt(-F0 / lam)
    major = evec[:, 0]
    angle = math.atan2(major[1], major[0])
    if angle <= -math.pi / 2:
        angle += math.pi
    elif angle > math.pi / 2:
        angle -= math.pi
    centre = (mx + sx * cu, my + sy * cv)
    chord = 2.0 * math.sqrt(-F0 / Qd[0, 0])
    # radial residual in the frame where the ellipse is the unit circle
    p = np.column_stack([x - centre[0], y - centre[1]]) @ evec
    r = np.hypot(p[:, 0] / semi[0], p[:, 1] / semi[1])
    residual = float(np.sqrt(np.mean((r - 1.0) ** 2)))
    return EllipseFit(
        conic=conic,
        centre=(float(centre[0]), float(centre[1])),
        axes=(float(semi[0]), float(semi[1])),
        angle=float(angle),
        chord_x=float(chord),
        axis_ratio=float(axis_ratio),
        residual=residual,
    )


@dataclass(frozen=True)
class ApparentStiction:
    """Result of :func:`apparent_stiction`.

    Attributes
    ----------
    stiction : float
        Apparent stiction (OP chord of the ellipse at its centre), OP units; NaN when
        no ellipse could be fitted.
    fit : EllipseFit or None
        The fitted ellipse (x = OP, y = PV).
    f0 : float
        Oscillation frequency used, fraction of the sampling frequency.
    f0_source : str
        ``"given"``, ``"acf"`` (regular ACF oscillation of OP, else of PV) or
        ``"welch"`` (largest Welch peak of OP, when neither is regular).
    band : (float, float)
        Band-pass applied, fractions of the sampling frequency.
    op, pv : ndarray
        Filtered, edge-trimmed signals the ellipse was fitted to (gain at ``f0``
        removed, means restored).
    """

    stiction: float
    fit: EllipseFit | None
    f0: float
    f0_source: str
    band: tuple[float, float]
    op: np.ndarray
    pv: np.ndarray


def apparent_stiction(
    op: np.ndarray,
    pv: np.ndarray,
    *,
    f0: float | None = None,
    band: tuple[float, float] = (0.5, 2.0),
    order: int = 2,
) -> ApparentStiction:
    """Apparent stiction: OP width of the ellipse fitted to band-passed (OP, PV).

    Steps: find the oscillation frequency ``f0`` (given; else the ACF zero-crossing
    period of OP, or of PV, when regular; else the largest Welch peak of OP), filter
    both signals with the same zero-phase Butterworth band-pass ``band·f0`` (the same
    filter on both keeps their phase relation; its gain at ``f0`` is divided out and
    the means are restored), drop three periods at each end (at most a sixth of the
    record: the filter's edge transients decay about fivefold per period), fit an
    ellipse (:func:`fit_ellipse`) to the (OP, PV) cloud and return its chord along OP
    through the centre.

    Parameters
    ----------
    op, pv : ndarray
        Controller output and process variable (same length, at least 64 samples).
    f0 : float, optional
        Oscillation frequency as a fraction of the sampling frequency.
    band : (float, float)
        Pass band as multiples of ``f0``; ``(0.5, 2.0)`` keeps the fundamental and
        rejects drift and most of the harmonics, so the cloud is close to an ellipse.
    order : int
        Butterworth order (run forwards and backwards).

    Returns
    -------
    ApparentStiction

    Raises
    ------
    InputError
        On non-finite, constant, mismatched or too short signals, or bad parameters.

    References
    ----------
    M. A. A. S. Choudhury, S. L. Shah, N. F. Thornhill, D. S. Shook, "Automatic detection
    and quantification of stiction in control valves", Control Eng. Practice 14 (2006)
    1395–1412 (ellipse fitting, apparent stiction).
    M. A. A. S. Choudhury, S. L. Shah, N. F. Thornhill, *Diagnosis of Process
    Nonlinearities and Valve Stiction*, Springer (2008), ch. 11.

    Examples
    --------
    >>> import numpy as np
    >>> t = np.arange(4000)
    >>> op = 5 * np.sin(2 * np.pi * t / 100)
    >>> pv = 2 * np.sin(2 * np.pi * t / 100 - np.pi / 6)
    >>> round(apparent_stiction(op, pv).stiction, 2)   # 2·5·sin(30°) = 5
    5.0
    """
    op = check_signal(op, "ellipse OP", min_len=MIN_SAMPLES)
    pv = check_signal(pv, "ellipse PV", min_len=MIN_SAMPLES)
    if op.size != pv.size:
        raise InputError(f"ellipse: OP has {op.size} samples, PV {pv.size}")
    lo_m, hi_m = float(band[0]), float(band[1])
    if not 0.0 <= lo_m < 1.0 < hi_m:
        raise InputError(f"ellipse: band={band!r} must satisfy 0 <= lo < 1 < hi (times f0)")
    source = "given"
    if f0 is None:
        source = "acf"
        osc = acf_oscillation(op)
        if not osc.oscillating:
            osc = acf_oscillation(pv)
        if osc.oscillating:
            f0 = 1.0 / osc.period_samples
        else:
            source = "welch"
            f0 = dominant_frequency(op)
    f0 = float(f0)
    if not 0.0 < f0 < 0.5:
        raise InputError(f"ellipse: f0={f0:g} must be in (0, 0.5) (fraction of fs)")
    bandf = (lo_m * f0, min(0.5, hi_m * f0))
    # Same filter on both signals: the phase relation at f0 is kept; dividing by the
    # filter gain at f0 keeps the amplitudes, and the means are put back for plotting.
    gain = bandpass_gain(bandf, f0, order)
    opf = bandpass(op - op.mean(), bandf, order) / gain + op.mean()
    pvf = bandpass(pv - pv.mean(), bandf, order) / gain + pv.mean()
    trim = min(int(round(3.0 / f0)), op.size // 6)
    if trim:
        opf, pvf = opf[trim:-trim], pvf[trim:-trim]
    fit = fit_ellipse(opf, pvf)
    return ApparentStiction(
        stiction=fit.chord_x if fit is not None else float("nan"),
        fit=fit,
        f0=f0,
        f0_source=source,
        band=bandf,
        op=opf,
        pv=pvf,
    )


class Ellipse(Estimator):
    """Apparent stiction by ellipse fitting (Choudhury et al. 2006).

    ``value`` is the apparent stiction: the width, along OP through its centre, of the
    ellipse fitted to band-passed (OP, PV), in OP units (% when OP is in % of span).
    ``decision`` is True when an ellipse was fitted, it is not degenerate
    (``axis_ratio >= min_axis_ratio``, unit-free, computed on standardised signals),
    it fits (radial ``residual <= max_residual``) and the apparent stiction exceeds
    ``min_stiction``. Any oscillating linear loop also traces an ellipse (PV lags
    OP through the process), so, as in the paper, read this as a *quantification* for
    a loop that a nonlinearity test (``bicoherence``) has already flagged.

    Parameters
    ----------
    f0 : float, optional
        Oscillation frequency, fraction of fs; default found from the data.
    band : (float, float)
        Band-pass as multiples of ``f0`` (0.5, 2.0).
    order : int
        Butterworth order (2).
    min_stiction : float
        Apparent stiction (OP units) above which stiction is reported (0.5 %).
    max_residual : float
        Largest acceptable RMS radial residual of the fit (0.3, i.e. points within
        about 30 % of the ellipse's radius on average).
    min_axis_ratio : float
        Smallest minor/major axis ratio of a non-degenerate ellipse (0.1; two
        equal-amplitude sinusoids give ``tan(φ/2)``, so about 11° of phase lag).
    """

    name = "ellipse"
    default_x = "OP"
    default_y = "PV"

    _parameter_constraints: ClassVar[dict[str, list[Constraint]]] = {
        "f0": [Interval(Real, 0, 0.5, closed="neither"), None],
        "band": [Band(0, None)],
        "order": [Interval(Integral, 1, 10)],
        "min_stiction": [Interval(Real, 0, None)],
        "max_residual": [Interval(Real, 0, None, closed="neither")],
        "min_axis_ratio": [Interval(Real, 0, 1)],
    }

    def __init__(
        self,
        f0: float | None = None,
        band: tuple[float, float] = (0.5, 2.0),
        order: int = 2,
        min_stiction: float = 0.5,
        max_residual: float = 0.3,
        min_axis_ratio: float = 0.1,
    ) -> None:
        self.f0 = f0
        self.band = band
        self.order = order
        self.min_stiction = min_stiction
        self.max_residual = max_residual
        self.min_axis_ratio = min_axis_ratio

    def _estimate(
        self, x: np.ndarray, y: np.ndarray | None, rec: Recording
    ) -> EstimateResult:
        if y is None:
            raise InputError("ellipse: needs two signals, OP (x) and PV (y)")
        res = apparent_stiction(
            x, y, f0=self.f0, band=tuple(self.band), order=self.order
        )
        fit = res.fit
        nan = float("nan")
        diagnostics: dict = {
            "f0": res.f0,
            "period_s": float(rec.Ts) / res.f0,
            "f0_source": res.f0_source,
            "band": res.band,
            "fitted": fit is not None,
            "min_stiction": self.min_stiction,
            "max_residual": self.max_residual,
            "min_axis_ratio": self.min_axis_ratio,
            "op_filtered": res.op,
            "pv_filtered": res.pv,
        }
        if fit is None:
            decision = False
            diagnostics.update(
                centre=(nan, nan), axes=(nan, nan), angle=nan, residual=nan,
                axis_ratio=0.0, chord_fraction=nan, degenerate=True,
            )
        else:
            degenerate = fit.axis_ratio < self.min_axis_ratio
            good_fit = fit.residual <= self.max_residual
            decision = bool(
                not degenerate and good_fit and fit.chord_x > self.min_stiction
            )
            op_span = float(np.ptp(fit.points(400)[:, 0]))
            diagnostics.update(
                centre=fit.centre,
                axes=fit.axes,
                angle=fit.angle,
                residual=fit.residual,
                axis_ratio=fit.axis_ratio,
                chord_fraction=fit.chord_x / op_span if op_span > 0 else nan,
                degenerate=bool(degenerate),
                ellipse=fit.points(200),
            )
        return EstimateResult(
            method=self.name,
            value=res.stiction,
            units="%",
            decision=decision,
            meaning="elliptic OP-PV cycle with apparent stiction above min_stiction",
            diagnostics=diagnostics,
        )
