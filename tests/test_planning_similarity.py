import numpy as np
import pytest

from interllm.planning.similarity import mean_nearest_distance, path_overlap, path_overlap_bruteforce


def line(x0, y0, x1, y1, n=21):
    t = np.linspace(0, 1, n)[:, None]
    return np.array([x0, y0]) + t * (np.array([x1, y1]) - np.array([x0, y0]))


def test_identical_paths_give_200():
    p = line(0, 0, 3, 1)
    assert path_overlap(p, p, 1.0) == pytest.approx(200.0)


def test_far_apart_paths_give_0():
    assert path_overlap(line(0, 0, 3, 0), line(0, 5, 3, 5), 1.0) == 0.0


def test_parallel_offset_hand_worked():
    # every point is 0.5 m from the other path: d_ij = d_ji = 0.5, eps = 1 -> 50 + 50
    p, q = np.array([[0, 0], [1, 0]]), np.array([[0, 0.5], [1, 0.5]])
    assert path_overlap(p, q, 1.0) == pytest.approx(100.0)


def test_asymmetric_terms_hand_worked():
    # p_i = {(0,0)}; p_j = {(0,0), (0,0.4)}: d_ij = 0 -> 100; d_ji = (0 + 0.4)/2 = 0.2 -> 80
    p, q = np.array([[0.0, 0.0]]), np.array([[0.0, 0.0], [0.0, 0.4]])
    assert mean_nearest_distance(p, q) == pytest.approx(0.0)
    assert mean_nearest_distance(q, p) == pytest.approx(0.2)
    assert path_overlap(p, q, 1.0) == pytest.approx(180.0)
    assert path_overlap(q, p, 1.0) == pytest.approx(180.0)


def test_each_term_is_clipped_separately():
    # d_ij = 0 -> 100; d_ji = (0 + 3)/2 = 1.5 > eps -> 0 (not negative)
    p, q = np.array([[0.0, 0.0]]), np.array([[0.0, 0.0], [0.0, 3.0]])
    assert path_overlap(p, q, 1.0) == pytest.approx(100.0)


def test_symmetric_and_matches_bruteforce_on_random_paths():
    rng = np.random.default_rng(3)
    for _ in range(20):
        p = np.cumsum(rng.normal(0, 0.2, (rng.integers(1, 60), 2)), axis=0)
        q = np.cumsum(rng.normal(0, 0.2, (rng.integers(1, 60), 2)), axis=0)
        eps = float(rng.uniform(0.2, 3.0))
        v = path_overlap(p, q, eps)
        assert 0.0 <= v <= 200.0
        assert v == pytest.approx(path_overlap(q, p, eps))
        assert v == pytest.approx(path_overlap_bruteforce(p, q, eps))


@pytest.mark.parametrize("bad", [np.zeros((0, 2)), np.zeros((3, 3)), np.zeros(4)])
def test_bad_paths_raise(bad):
    with pytest.raises(ValueError, match=r"\[N, 2\]"):
        path_overlap(bad, line(0, 0, 1, 1), 1.0)


def test_bad_eps_raises():
    with pytest.raises(ValueError, match="epsilon_d"):
        path_overlap(line(0, 0, 1, 1), line(0, 0, 1, 1), 0.0)
