"""Replication of Govinda Kumar & Manoharan, *A Novel Approach for Detection of Valve
Stiction by Time Delay Estimation* (``../shared/paper/``).

Modules, in the order :func:`stictionbench.paper.command.replicate` uses them:

- :mod:`.cases` — the four cases simulated, the estimators applied, the remark measures;
- :mod:`.tables` — Tables III–VII, each remark decided by a measured number;
- :mod:`.mechanism` — what the stiction-case estimates measure (slip → CO-reversal
  lags, harmonic phases, cumulant conditioning, bicoherence vs record length) and the
  open-loop valve test of the paper's premise;
- :mod:`.sensitivity` — the unstated choices swept (``conf/sweep/paper_*.yaml``): rates
  with Wilson intervals, ROC areas with bootstrap intervals;
- :mod:`.figures` — Figures 1–21 and the sensitivity figures;
- :mod:`.narrative` — ``reports/REPLICATION.md``;
- :mod:`.command` — the ``stictionbench replicate`` sub-command.
"""
