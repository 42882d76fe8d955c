"""Diagnosis: why does my simulation not match this recording?"""

from .diagnose import Diagnosis, diagnose, identify_fopdt
from .hypotheses import VOCABULARY
from .model import NominalModel, load_model

__all__ = ["VOCABULARY", "Diagnosis", "NominalModel", "diagnose", "identify_fopdt",
           "load_model"]
