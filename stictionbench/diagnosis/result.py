"""The diagnosis's answer: :class:`Diagnosis`, what :func:`.diagnose.diagnose` returns
and ``stictionbench diagnose --json`` writes (:meth:`Diagnosis.to_json`)."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from ..recording import Recording
from .fit import Fit
from .model import NominalModel


@dataclass
class Diagnosis:
    """The result of :func:`diagnose`; :meth:`to_json` gives the CLI's JSON."""

    mismatch_detected: bool
    missing_physics: str
    parameters: dict[str, Any]
    fit: dict[str, Any]
    mismatch_windows: list[list[float]]
    mismatch_band_hz: list[float]
    ranking: list[dict[str, Any]]
    model: NominalModel
    uncertainty: dict[str, list[float]]
    details: dict[str, Any] = field(default_factory=dict)
    noise_model: dict[str, Any] = field(default_factory=dict)
    tests: dict[str, Any] = field(default_factory=dict)
    # arrays for the report (not in JSON)
    rec: Recording | None = field(default=None, repr=False)
    fits: dict[str, Fit] = field(default_factory=dict, repr=False)
    spectrum: dict[str, Any] = field(default_factory=dict, repr=False)
    train_end: int = 0
    val_blocks: list[list[float]] = field(default_factory=list)
    burn: int = 0

    def to_json(self) -> dict[str, Any]:
        return {
            "mismatch_detected": bool(self.mismatch_detected),
            "missing_physics": self.missing_physics,
            "parameters": self.parameters,
            "fit": self.fit,
            "mismatch_windows": self.mismatch_windows,
            "mismatch_band_hz": self.mismatch_band_hz,
            "ranking": self.ranking,
            "uncertainty": self.uncertainty,
            "noise_model": self.noise_model,
            "tests": self.tests,
            "nominal_model": self.model.to_dict(),
            "details": {k: v for k, v in self.details.items() if not k.startswith("_")},
        }
