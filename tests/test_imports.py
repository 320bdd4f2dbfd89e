"""The layering (worlds -> sim -> slam -> metrics -> bench), no algorithm importing another, and
no SLAM reading a world: import-linter's contracts in pyproject.toml, kept and able to break."""
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LINT = shutil.which("lint-imports")
pytestmark = pytest.mark.skipif(LINT is None, reason="import-linter is in the test extra")


def _lint(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([LINT, "--no-cache", *args], cwd=ROOT, capture_output=True, text=True)


def test_the_import_contracts_are_kept():
    done = _lint()
    assert done.returncode == 0, done.stdout[-2000:]
    assert "3 kept, 0 broken" in done.stdout


def test_a_reversed_layering_is_reported_broken(tmp_path):
    """The same packages with the layers upside down: every real import is then a violation."""
    text = (ROOT / "pyproject.toml").read_text()
    reversed_layers = text.replace('layers = ["bench", "metrics", "slam", "sim", "worlds"]',
                                   'layers = ["worlds", "sim", "slam", "metrics", "bench"]')
    assert reversed_layers != text
    config = tmp_path / "pyproject.toml"
    config.write_text(reversed_layers)
    done = _lint("--config", str(config))
    assert done.returncode != 0 and "BROKEN" in done.stdout
