"""Scan normals kernel against its numpy reference, and the information their directions carry."""
import numpy as np
import pytest

from slam.gn._normals_kernel import normal_information, scan_normals, scan_normals_ref


def _ring_scan(rng, n=300):
    """Points of a noisy closed contour in scan order, with some occluding jumps."""
    ang = np.linspace(0, 2 * np.pi, n, endpoint=False)
    r = rng.uniform(0.5, 3.5) * (1 + 0.3 * np.cos(3 * ang)) + rng.normal(0, 0.02, n)
    r[rng.random(n) < 0.1] *= 1.5
    return np.c_[r * np.cos(ang), r * np.sin(ang)]


@pytest.mark.kernel
@pytest.mark.parametrize("seed", range(5))
@pytest.mark.parametrize("half", [1, 2, 4])
def test_kernel_matches_reference(seed, half):
    pts = _ring_scan(np.random.default_rng(seed))
    a = scan_normals(pts, half, 0.2)
    b = scan_normals_ref(pts, half, 0.2)
    none_a, none_b = ~a.any(axis=1), ~b.any(axis=1)
    np.testing.assert_array_equal(none_a, none_b)
    assert none_a.sum() < len(pts) // 2            # most points have a normal
    # unit vectors, equal up to sign
    np.testing.assert_allclose(np.linalg.norm(a[~none_a], axis=1), 1.0)
    np.testing.assert_allclose(np.abs(np.einsum("ij,ij->i", a, b))[~none_a], 1.0, atol=1e-9)


def test_a_straight_wall_has_its_perpendicular_and_isolated_points_none():
    x = np.linspace(-1, 1, 41)
    wall = np.c_[x, np.full_like(x, 2.0)]
    lone = np.array([[5.0, 5.0], [-5.0, 5.0]])             # far from each other and the wall
    n = scan_normals(np.vstack([wall, lone]), 2, 0.2)
    np.testing.assert_allclose(np.abs(n[:41, 1]), 1.0, atol=1e-12)
    assert not n[41:].any()


def test_information_is_small_along_a_corridor_and_large_in_a_room():
    y = np.linspace(-3, 3, 121)
    corridor = np.vstack([np.c_[np.full_like(y, -0.8), y], np.c_[np.full_like(y, 0.8), y[::-1]]])
    lam, vec = np.linalg.eigh(normal_information(scan_normals(corridor, 2, 0.2)))
    assert lam[0] < 1e-6 and abs(vec[1, 0]) == pytest.approx(1.0)   # y, along the walls
    s = np.linspace(-1, 1, 41)
    room = np.vstack([np.c_[s, np.full_like(s, -1)], np.c_[np.full_like(s, 1), s],
                      np.c_[s[::-1], np.full_like(s, 1)], np.c_[np.full_like(s, -1), s[::-1]]])
    lam, _ = np.linalg.eigh(normal_information(scan_normals(room, 2, 0.2)))
    assert lam[0] > 0.4
    assert not normal_information(np.zeros((0, 2))).any()
