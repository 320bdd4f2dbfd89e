"""Shared fixtures: Agg backend, tiny worlds, a seeded rng."""
import matplotlib

matplotlib.use("Agg")

import numpy as np
import pytest


def pytest_configure(config):
    config.addinivalue_line("markers", "kernel: numba kernel checked against its numpy reference")


@pytest.fixture
def rng():
    return np.random.default_rng(12345)
