"""A toy third-party estimator: the lag of the plain cross-correlation peak."""

from numbers import Integral

import numpy as np

from stictionbench.estimators import EstimateResult, Estimator
from stictionbench.validation import Interval


class PeakLag(Estimator):
    """Lag (samples) at which ``y`` best matches ``x`` (positive: y lags x)."""

    name = "peak_lag"
    _parameter_constraints = {"max_lag": [Interval(Integral, 1, None)]}

    def __init__(self, max_lag: int = 20) -> None:
        self.max_lag = max_lag

    def _estimate(self, x, y, rec):
        x = x - x.mean()
        y = y - y.mean()
        lags = np.arange(-self.max_lag, self.max_lag + 1)
        c = [np.dot(x[max(0, -k): x.size - max(0, k)], y[max(0, k): y.size - max(0, -k)])
             for k in lags]
        lag = int(lags[int(np.argmax(c))])
        return EstimateResult(self.name, float(lag), "samples", lag > 0, "y lags x",
                              {"max_lag": self.max_lag})
