"""Benchmark: path overlap P° with scipy cKDTree vs brute-force numpy pairwise distances.

Two 2,000-point random-walk paths [m]; prints ms per call and the speed-up (goal >= 50x), and
checks both give the same value.

    .venv/bin/python benchmarks/bench_similarity.py
"""

from __future__ import annotations

# isort: off
import interllm  # noqa: F401  (first: pins BLAS and SIMD before numpy loads; interllm/numerics.py)
# isort: on

import sys
import time

import numpy as np
from _usage import no_arguments  # benchmarks/_usage.py, beside this script

from interllm.planning.similarity import path_overlap, path_overlap_bruteforce


def timeit(fn, *args, repeat: int = 5, number: int = 10) -> float:
    best = float("inf")
    for _ in range(repeat):
        t = time.perf_counter()
        for _ in range(number):
            fn(*args)
        best = min(best, (time.perf_counter() - t) / number)
    return best


def main(n: int = 2000, eps: float = 1.0) -> dict:
    rng = np.random.default_rng(0)
    p = np.cumsum(rng.normal(0, 0.05, (n, 2)), axis=0)
    q = p + rng.normal(0, 0.3, (n, 2))
    a, b = path_overlap(p, q, eps), path_overlap_bruteforce(p, q, eps)
    assert abs(a - b) < 1e-9, (a, b)
    t_kd = timeit(path_overlap, p, q, eps)
    t_bf = timeit(path_overlap_bruteforce, p, q, eps, repeat=3, number=2)
    out = {"n_points": n, "P_overlap": round(a, 6), "ckdtree_ms": t_kd * 1e3, "bruteforce_ms": t_bf * 1e3,
           "speedup": t_bf / t_kd}
    print(f"P° of two {n}-point paths = {a:.3f} (both methods)")
    print(f"cKDTree     : {t_kd * 1e3:8.2f} ms/call")
    print(f"brute force : {t_bf * 1e3:8.2f} ms/call")
    print(f"speed-up    : {t_bf / t_kd:8.1f}x (goal >= 50x)")
    return out


if __name__ == "__main__":
    no_arguments(sys.argv[1:], __doc__)
    main()
