"""Test session set-up. Importing interllm first pins the numerical environment (BLAS kernel and
threads, numpy's SIMD targets) before any test module imports numpy: see interllm/numerics.py."""

import interllm  # noqa: F401  (must stay the first import: it pins the numerics before numpy loads)
