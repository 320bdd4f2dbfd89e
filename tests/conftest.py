"""Shared fixtures: Agg backend, a seeded rng, paths that cannot be written."""
import os
import subprocess

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pytest


def pytest_configure(config):
    config.addinivalue_line("markers", "kernel: numba kernel checked against its numpy reference")


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


@pytest.fixture
def read_only_dir(tmp_path):
    """A folder this process cannot write: mode 0o555, and for root (whom modes do not stop)
    the immutable attribute (chattr +i); skips where neither holds."""
    d = tmp_path / "read_only"
    d.mkdir()
    d.chmod(0o555)
    immutable = False
    if os.access(d, os.W_OK):
        immutable = subprocess.run(["chattr", "+i", str(d)], capture_output=True).returncode == 0
        if not immutable or _writable(d):
            _release(d, immutable)
            pytest.skip("this user can write a read-only folder")
    yield d
    _release(d, immutable)


def _writable(d) -> bool:
    try:
        (d / ".probe").touch()
    except OSError:
        return False
    (d / ".probe").unlink()
    return True


def _release(d, immutable: bool) -> None:
    if immutable:
        subprocess.run(["chattr", "-i", str(d)], capture_output=True)
    d.chmod(0o755)


@pytest.fixture
def a_file(tmp_path):
    """A regular file, to stand where a folder is expected (works as root too)."""
    f = tmp_path / "a_file.txt"
    f.write_text("not a folder\n")
    return f


@pytest.fixture
def interrupted_main(monkeypatch):
    """call(module, argv): run module.main(argv) with Ctrl-C pressed during its start-up
    (in build_parser); returns the exit code. A KeyboardInterrupt escaping main() fails the
    test instead of ending the test session."""
    def call(module, argv):
        def build_parser():
            raise KeyboardInterrupt
        monkeypatch.setattr(module, "build_parser", build_parser)
        try:
            return module.main(argv)
        except KeyboardInterrupt:
            pytest.fail("KeyboardInterrupt escaped main()")
    return call
