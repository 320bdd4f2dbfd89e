import numpy as np
import pytest

from sim._raycast import cast_rays, cast_rays_ref
from tests.sim.worlds_fixtures import square_room


@pytest.mark.kernel
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_kernel_matches_reference(seed):
    rng = np.random.default_rng(seed)
    segs = rng.uniform(-3, 3, (60, 4))
    origins = rng.uniform(-1, 1, (500, 2))
    angles = rng.uniform(-np.pi, np.pi, 500)
    for max_range in (1.0, 3.5, np.inf):
        got = cast_rays(segs, origins, angles, max_range)
        want = cast_rays_ref(segs, origins, angles, max_range)
        assert np.array_equal(np.isinf(got), np.isinf(want))
        fin = np.isfinite(want)
        np.testing.assert_allclose(got[fin], want[fin], rtol=1e-12, atol=1e-12)


@pytest.mark.kernel
def test_kernel_matches_reference_on_world_segments():
    segs = square_room().segments
    rng = np.random.default_rng(3)
    origins = rng.uniform(0.2, 3.8, (300, 2))
    angles = rng.uniform(0, 2 * np.pi, 300)
    np.testing.assert_allclose(cast_rays(segs, origins, angles, 3.5),
                               cast_rays_ref(segs, origins, angles, 3.5))


@pytest.mark.kernel
def test_no_segments_and_parallel_rays():
    o = np.zeros((2, 2))
    a = np.array([0.0, np.pi / 2])
    assert np.isinf(cast_rays(np.zeros((0, 4)), o, a, 5.0)).all()
    assert np.isinf(cast_rays_ref(np.zeros((0, 4)), o, a, 5.0)).all()
    # a segment parallel to beam 0, and crossed by beam 1 at distance 1
    seg = np.array([[-1.0, 1.0, 1.0, 1.0]])
    for f in (cast_rays, cast_rays_ref):
        r = f(seg, o, a, 5.0)
        assert np.isinf(r[0]) and r[1] == pytest.approx(1.0)


def test_hand_computed_distances_in_a_unit_box():
    seg = np.array([[0, 0, 2, 0], [2, 0, 2, 2], [2, 2, 0, 2], [0, 2, 0, 0]], float)
    o = np.array([[0.5, 1.0]] * 4)
    a = np.array([0, np.pi / 2, np.pi, np.pi / 4])
    r = cast_rays(seg, o, a, 10.0)
    np.testing.assert_allclose(r, [1.5, 1.0, 0.5, np.sqrt(2)], atol=1e-12)
    assert np.isinf(cast_rays(seg, o, a, 0.9)[[0, 1, 3]]).all()
