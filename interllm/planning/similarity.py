"""Path similarity P° of the multimodal action-cost similarity function (paper eq. 7).

P°(p_i, p_j) = 100·(1 − d_ij/ε) + 100·(1 − d_ji/ε), each term clipped to [0, 100], where d_ij
is the mean over the points of p_i of the distance to the nearest point of p_j [m] and ε the
distance [m] beyond which two points do not overlap. Identical paths give 200, paths farther
apart than ε everywhere give 0, and P° is symmetric.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree


def _as_path(p, name: str) -> np.ndarray:
    a = np.asarray(p, dtype=float)
    if a.ndim != 2 or a.shape[1] != 2 or a.shape[0] == 0:
        raise ValueError(f"{name} must be a non-empty [N, 2] array of (x, y) points [m], got shape {a.shape}")
    return a


def mean_nearest_distance(p_i, p_j) -> float:
    """d_ij: mean over the points of ``p_i`` of the distance to the nearest point of ``p_j`` [m]."""
    a, b = _as_path(p_i, "p_i"), _as_path(p_j, "p_j")
    dist, _ = cKDTree(b).query(a, k=1)
    return float(np.mean(dist))


def path_overlap(p_i, p_j, eps: float) -> float:
    """P°(p_i, p_j) in [0, 200]; ``p_i``, ``p_j``: [N, 2] paths [m]; ``eps``: ε [m] (> 0)."""
    if not eps > 0:
        raise ValueError(f"eps (planner.inter_llm.epsilon_d) must be > 0 m, got {eps}")
    d_ij = mean_nearest_distance(p_i, p_j)
    d_ji = mean_nearest_distance(p_j, p_i)
    t_ij = min(max(100.0 * (1.0 - d_ij / eps), 0.0), 100.0)
    t_ji = min(max(100.0 * (1.0 - d_ji / eps), 0.0), 100.0)
    return t_ij + t_ji


def path_overlap_bruteforce(p_i, p_j, eps: float) -> float:
    """Reference implementation with the full pairwise distance matrix (O(N·M) memory)."""
    a, b = _as_path(p_i, "p_i"), _as_path(p_j, "p_j")
    d = np.sqrt(((a[:, None, :] - b[None, :, :]) ** 2).sum(-1))
    d_ij, d_ji = d.min(axis=1).mean(), d.min(axis=0).mean()
    return float(np.clip(100 * (1 - d_ij / eps), 0, 100) + np.clip(100 * (1 - d_ji / eps), 0, 100))
