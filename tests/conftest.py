"""Shared fixtures for the e2vlib tests, the Hypothesis profiles and the ``slow`` tier.

Hypothesis profiles: ``HYPOTHESIS_PROFILE=quick`` (what ``make test`` sets) draws 10 examples
per property; ``full`` (``make test-all`` and the default) draws 150. Tests marked
``@pytest.mark.slow`` (end-to-end training, CLI runs) are deselected by ``make test``
(``-m "not slow"``) and run by ``make test-all``.
"""

import os
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, settings

from e2vlib.events import make_events

REPO = Path(__file__).resolve().parents[1]
REAL_RECORDING = REPO / "data_small" / "real" / "davis346_sample.aedat4"

# database=None: no .hypothesis/ folder is written into the repository
for _name, _examples in (("quick", 10), ("full", 150)):
    settings.register_profile(_name, max_examples=_examples, deadline=None, database=None,
                              suppress_health_check=[HealthCheck.too_slow])
_profile = os.environ.get("HYPOTHESIS_PROFILE", "full")
if _profile not in ("quick", "full"):
    raise pytest.UsageError(f"HYPOTHESIS_PROFILE={_profile!r} is unknown: set it to quick "
                            "(10 examples per property) or full (150), or leave it unset (full)")
settings.load_profile(_profile)


@pytest.fixture
def small_events() -> np.ndarray:
    """Six hand-placed events on a 4 x 3 sensor (width 4, height 3), times in us."""
    return make_events(
        x=[0, 1, 1, 3, 0, 2],
        y=[0, 0, 0, 2, 1, 2],
        t=[0, 10, 4999, 5000, 9999, 10000],
        p=[1, -1, 1, 1, -1, -1],
    )


@pytest.fixture
def random_events() -> tuple[np.ndarray, tuple[int, int]]:
    """20,000 random sorted events on a 32 x 24 sensor over 0.5 s."""
    rng = np.random.default_rng(0)
    n = 20_000
    t = np.sort(rng.integers(0, 500_000, n))
    ev = make_events(rng.integers(0, 32, n), rng.integers(0, 24, n), t, rng.integers(0, 2, n))
    return ev, (32, 24)
