"""The numba kernels that run long enough to matter release the GIL (nogil=True), so a
threaded or Dask worker stays responsive while one runs."""
import importlib

import pytest

KERNELS = {
    "slam._kernels.insert": ["insert_rays_inplace"],
    "slam._kernels.gauss_newton": ["gn_iterate", "gn_normal_equations", "solve3"],
    "slam.pf._match_kernel": ["hill_climb", "proposal_moments"],
    "slam.pf._map_kernel": ["insert_scans", "tiles_bound", "patch_box", "read_patch"],
    "slam.pf._refine_kernel": ["line_iterate", "line_normal_equations"],
    "slam.pf._proposal_kernel": ["propose_particles"],
    "slam.graph._match_kernel": ["match_lm", "match_lm_directional"],
    "slam.graph._tsdf_kernel": ["tsdf_insert", "estimate_normals"],
    "slam.graph._correlative_kernel": ["bnb_search", "score_candidates", "max_grids"],
    "slam.gn._normals_kernel": ["scan_normals"],
    "metrics._surface_kernel": ["surface_match"],
}


@pytest.mark.parametrize("module, name", [(m, n) for m, names in KERNELS.items() for n in names])
def test_kernel_releases_the_gil(module, name):
    kernel = getattr(importlib.import_module(module), name)
    assert kernel.targetoptions.get("nogil") is True, f"{module}.{name}"


def test_the_simulator_ray_caster_releases_the_gil():
    raycast = importlib.import_module("sim._raycast")
    jitted = [getattr(raycast, n) for n in dir(raycast) if hasattr(getattr(raycast, n), "targetoptions")]
    assert jitted and all(k.targetoptions.get("nogil") for k in jitted
                          if not k.targetoptions.get("inline") == "always")
