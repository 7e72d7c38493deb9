import numpy as np
import pytest

from core.layering.gaussian_peak import largest_gaussian


def brute(points, centres, amplitude, c, reach):
    """Every (point, bump) pair, as the definition reads."""
    x = np.linalg.norm(points[:, None, :] - centres[None, :, :], axis=2)
    w = np.where(x <= reach, amplitude[None, :] * np.exp(-(x**2) / (2 * c * c)), 0.0)
    return w.max(axis=1, initial=0.0)


def case(seed, n=3000, m=60, spread=1.0, amp_range=(0.2, 1.0)):
    rng = np.random.default_rng(seed)
    points = rng.uniform(-spread, spread, (n, 3))
    centres = rng.uniform(-spread, spread, (m, 3))
    amplitude = rng.uniform(*amp_range, m)
    return points, centres, amplitude


@pytest.mark.parametrize("scale", [1e-3, 1.0, 1e3])
def test_matches_every_pair_at_all_scales(scale):
    points, centres, amplitude = case(1)
    c, reach = 0.15, 0.45
    got = largest_gaussian(points * scale, centres * scale, amplitude * scale, c * scale, reach * scale)
    np.testing.assert_allclose(got, brute(points, centres, amplitude, c, reach) * scale, rtol=1e-12, atol=0)
    assert (got > 0).sum() > 100 and (got == 0).sum() > 100  # both within and beyond reach


def test_truncation_when_the_largest_bump_lies_beyond_reach():
    # amplitudes spanning 300 orders: far strong bumps would win untruncated, the near weak one
    # must win (the points the pairs answer)
    points, centres, amplitude = case(2, amp_range=(0.0, 1.0))
    amplitude = 10.0 ** -np.random.default_rng(3).uniform(0, 300, len(centres))
    c, reach = 0.05, 0.15
    untruncated = np.linalg.norm(points[:, None] - centres[None], axis=2)
    best = np.argmax(np.log(amplitude)[None] - untruncated**2 / (2 * c * c), axis=1)
    beyond = untruncated[np.arange(len(points)), best] > reach
    want = brute(points, centres, amplitude, c, reach)
    assert (beyond & (want > 0)).sum() > 20
    np.testing.assert_allclose(largest_gaussian(points, centres, amplitude, c, reach), want, rtol=1e-12, atol=0)


def test_zero_bumps_coincident_centres_and_no_centres():
    points, centres, amplitude = case(4, m=20)
    centres[10:] = centres[:10]  # each centre twice, with another amplitude
    amplitude[::3] = 0.0
    c, reach = 0.3, 0.9
    np.testing.assert_allclose(largest_gaussian(points, centres, amplitude, c, reach),
                               brute(points, centres, amplitude, c, reach), rtol=1e-12, atol=0)
    assert not largest_gaussian(points, centres, np.zeros(20), c, reach).any()
    assert not largest_gaussian(points, np.zeros((0, 3)), np.zeros(0), c, reach).any()
    assert largest_gaussian(np.zeros((0, 3)), centres, amplitude, c, reach).shape == (0,)


def test_a_point_on_a_centre_takes_its_whole_amplitude():
    centres = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    got = largest_gaussian(centres.copy(), centres, np.array([2.0, 0.5]), 0.1, 0.3)
    np.testing.assert_array_equal(got, [2.0, 0.5])


def test_a_point_on_a_weak_centre_beside_a_strong_one_out_of_reach():
    # the lifted search names the strong bump (0.35 away, beyond reach): the pairs must still see
    # the weak one at distance 0
    centres = np.array([[0.0, 0.0, 0.0], [0.35, 0.0, 0.0]])
    got = largest_gaussian(centres[:1].copy(), centres, np.array([1e-6, 1.0]), 0.1, 0.3)
    np.testing.assert_array_equal(got, [1e-6])
