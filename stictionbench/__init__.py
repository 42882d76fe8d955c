"""stictionbench: reproducible control-valve stiction detection and loop diagnosis."""

from .errors import InputError
from .recording import Recording

__version__ = "0.1.0"

__all__ = ["InputError", "Recording", "__version__", "simulate"]


def simulate(case: str = "stiction", duration: float | None = None, seed: int = 0, **overrides):
    """Simulate a closed loop from the Hydra configs.

    See :func:`stictionbench.sim.compose.simulate` for the parameters.
    """
    from .sim.compose import simulate as _simulate

    return _simulate(case=case, duration=duration, seed=seed, **overrides)
