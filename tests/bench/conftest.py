"""Bench fixtures: the tiny world, the fake algorithms, a private log cache per session."""
from pathlib import Path

import pytest

import tests.bench.fakes  # noqa: F401  (registers fake_map, fake_raise, ...)

TINY = str(Path(__file__).with_name("tiny_world.yaml"))


@pytest.fixture(autouse=True)
def _log_cache(tmp_path_factory, monkeypatch):
    monkeypatch.setenv("SLAM_BENCH_CACHE", str(tmp_path_factory.getbasetemp() / "logcache"))


@pytest.fixture
def tiny():
    return TINY
