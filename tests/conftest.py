"""Shared fixtures for the e2vlib tests."""

from pathlib import Path

import numpy as np
import pytest

from e2vlib.events import make_events

REPO = Path(__file__).resolve().parents[1]
REAL_RECORDING = REPO / "data_small" / "real" / "davis346_sample.aedat4"


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
