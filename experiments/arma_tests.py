"""The diagnosis with an ARMA noise model in its likelihood tests only, against the shipped
AR one, on the sets A–I and on two fresh sets drawn for it, against a criterion written
before either run.

Why: ``arma_stages.py`` (exploratory, on the 264 healthy loops of ``arma_diagnosis.py``)
found that the extra healthy loops ``noise_family="arma"`` calls physics all come from its
ARMA models outside the tests (the prediction-error refit, the valve identification, the
set-point gain test), and that an ARMA family in the likelihood tests alone called fewer
healthy loops physics than AR (25 → 19 of 264, McNemar 0 / 6, p = 0.031). Those loops
prompted the idea, so that number is in-sample. This run scores the variant
``test_noise_family="arma"`` (AR in every fit, the ARMA family in
:func:`stictionbench.diagnosis.evidence.validate`) on every class.

Recordings: every recording of the independent sets A–I (1728; their ``ar`` verdicts are
the stored ones; their healthy loops are in-sample for the idea) and two fresh sets
drawn for this run, generator A from seed 83000 and generator C from seed 85000, 12
recordings per class and level each (384, out of sample), under both.

**Prediction, written before the run.** As in ``arma_diagnosis.py``: the healthy loops'
validation innovations are whiter under the variant (Ljung–Box at 20 lags rejecting at 5 %
less often).

**Criterion, written before the run**: the five parts of ``arma_diagnosis.py``'s, with the
variant in ARMA's place. It becomes the default only if on the fresh sets pooled (1) no more
healthy loops are called physics than under AR, (2) the score of 16 at each level is not
lower by more than 0.25, (3) it gains (fewer healthy loops called physics, or a level's
score up by at least 0.25); (4) (1) and (2) also hold on sets A–I; (5) a diagnosis stays
within 2 s (median on the fresh sets).

Run: ``.venv/bin/python experiments/arma_tests.py [--jobs 2] [--reuse]`` after ``make
independent`` (the fresh sets are generated here); writes
``reports/concealed/arma_tests.{md,csv}`` (about 30 minutes on 2 cores).
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "experiments"))

from arma_diagnosis import Design, main  # noqa: E402

TESTS_ONLY = Design(
    "arma_tests", "ARMA in the tests",
    {"armatests_a": ("blind_generator", 83000), "armatests_c": ("blind_generator_c", 85000)},
    "arma_tests", "The diagnosis with an ARMA noise model in its likelihood tests only",
    "AR models in every fit, and AR or ARMA / ARIMA models of low order by BIC in the "
    "likelihood tests' noise model (`test_noise_family=\"arma\"`)")

if __name__ == "__main__":
    raise SystemExit(main(d=TESTS_ONLY, doc=__doc__))
