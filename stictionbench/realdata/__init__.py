"""Real plant recordings: loading, data-quality screening, verdicts and their scoring.

- :mod:`.datasets` — loaders (CSV folders with ``labels.csv``, ISDB ``.mat``, the
  oscillation-detection benchmark);
- :mod:`.quality` — the data-quality screen of one recording;
- :mod:`.verdict` — a stiction verdict per recording;
- :mod:`.oscillation_benchmark` — the oscillation-detection benchmark report;
- :mod:`.compare`, :mod:`.consensus` — the published detectors side by side, their
  combined verdict, and verdicts by physical loop scored against labels;
- :mod:`.screening`, :mod:`.batch`, :mod:`.comparison` — what the ``screen``,
  ``oscillation-benchmark``, ``batch`` and ``compare`` sub-commands do; :mod:`.command`
  registers them (listed in ``stictionbench.cli.COMMAND_MODULES``).
"""
