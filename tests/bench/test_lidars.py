"""Worlds crossed with lidars: a suite's `lidar:` field, `bench run --lidar`, the world keys
WORLD+LIDAR and the log cache key."""
import pytest

from bench.cache import log_key
from bench.plan import RunSpec
from bench.runner import cross_lidars
from bench.spec import spec_from_options
from bench.suite import load_suite
from worlds.yamlio import InputError


def _suite(tmp_path, lidar_line):
    p = tmp_path / "s.yaml"
    p.write_text(f"name: s\ndraws: 1\n{lidar_line}\nworlds: [rectangle_s, corridor]\n")
    return p


def test_a_suite_crosses_its_worlds_with_its_lidars(tmp_path):
    (tmp_path / "mine.yaml").write_text("model: mine\nbeams: 90\nangle_min_deg: -45\nangle_max_deg: 45\n")
    s = load_suite(_suite(tmp_path, "lidar: [utm-30lx, mine.yaml, utm-30lx]"))
    assert s.lidars == ("utm-30lx", str((tmp_path / "mine.yaml").resolve()))
    spec = spec_from_options(suite=str(_suite(tmp_path, "lidar: [utm-30lx, mine.yaml]")), algo="oracle")
    assert spec.lidars == s.lidars
    worlds, files, of = cross_lidars({"rectangle_s": 1, "corridor": 2}, {"rectangle_s": None, "corridor": None},
                                     spec.lidars)
    assert list(worlds) == ["rectangle_s+utm-30lx", "rectangle_s+mine", "corridor+utm-30lx", "corridor+mine"]
    assert of["corridor+mine"].endswith("mine.yaml") and worlds["corridor+utm-30lx"] == 2
    # --lidar on the command line wins over the suite's
    assert spec_from_options(suite=str(_suite(tmp_path, "lidar: tim571")), algo="oracle",
                             lidar="lds-02").lidars == ("lds-02",)
    assert load_suite(_suite(tmp_path, "")).lidars == ()


@pytest.mark.parametrize("line, match", [
    ("lidar: sick-9000", r"s.yaml: lidar: unknown lidar 'sick-9000'"),
    ("lidar: [lds-01, 5]", r"s.yaml: lidar\[1\]: expected a lidar name or a .yaml path, got 5"),
    ("lidar: []", r"s.yaml: lidar: expected a lidar name, a .yaml path or a list"),
    ("lidar: [nothere.yaml]", r"s.yaml: lidar\[0\]: .*nothere.yaml: file not found"),
])
def test_bad_lidar_fields_are_one_line_errors(tmp_path, line, match):
    with pytest.raises(InputError, match=match):
        load_suite(_suite(tmp_path, line))


def test_runspec_lidars_are_checked():
    with pytest.raises(InputError, match="--lidar must be a list"):
        RunSpec(worlds=("rectangle_s",), algos=("oracle",), lidars="utm-30lx")
    with pytest.raises(InputError, match="a run on given --logs takes their lidar"):
        RunSpec(worlds=("w",), algos=("oracle",), logs=("/x.npz",), lidars=("utm-30lx",))


def test_the_default_lidar_keeps_the_cache_key_and_another_changes_it():
    class W:
        name, source = "w", ""
    base = log_key(W(), 0, "realistic", "3")
    assert log_key(W(), 0, "realistic", "3", lidar=None) == base
    assert log_key(W(), 0, "realistic", "3", lidar="utm-30lx") != base
    assert log_key(W(), 0, "realistic", "3", lidar="utm-30lx") != log_key(W(), 0, "realistic", "3", lidar="tim571")


def test_two_lidar_files_of_one_name_are_refused():
    with pytest.raises(InputError, match=r"another lidar of the run is also named 'mine'"):
        cross_lidars({"w": 1}, {"w": None}, ("/a/mine.yaml", "/b/mine.yaml"))
    with pytest.raises(InputError, match=r"--lidar /a/my lidar.yaml: .*holds characters"):
        cross_lidars({"w": 1}, {"w": None}, ("/a/my lidar.yaml",))
