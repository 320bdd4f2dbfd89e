"""setuptools finds the project's packages by their __init__.py (pyproject.toml), so every
folder of Python modules inside them needs one, or a non-editable install leaves it out."""
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("worlds", "sim", "slam", "metrics", "bench")


def test_every_folder_of_modules_is_a_package():
    missing = sorted(str(d.relative_to(ROOT)) for top in PACKAGES
                     for d in [ROOT / top, *(ROOT / top).rglob("*")]
                     if d.is_dir() and d.name != "__pycache__" and any(d.glob("*.py"))
                     and not (d / "__init__.py").is_file())
    assert not missing, f"folders without __init__.py (not installed): {missing}"
