"""Which caller environments reproduce the committed metrics.json, with the numerics pin and without.

    .venv/bin/python benchmarks/bench_numerics.py            # every setting (about 1 min each)
    .venv/bin/python benchmarks/bench_numerics.py --only Haswell SkylakeX

Each setting runs tests/test_reproduce.py's reproduction (the default experiment from the
committed LLM cache, compared byte for byte with git HEAD's data/metrics/metrics.json) in a fresh
process whose environment sets what the caller of `make test` might have set. The first group
runs with the pin (interllm/numerics.py overrides those variables); the control group sets
INTERLLM_NUMERICS=inherit, so the caller's choice takes effect, to show what the pin prevents.
"yes": byte-identical; "approx": not byte-identical but no conclusion changed, on a machine where
the numerics cannot be pinned (another ISA, no AVX2); "NO": the test failed.
"""

from __future__ import annotations

# isort: off
import interllm  # noqa: F401  (first: pins BLAS and SIMD before numpy loads; interllm/numerics.py)
# isort: on

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
AVX512_OFF = "X86_V4 AVX512_ICL AVX512_SPR"
SETTINGS = [  # (label, environment the caller sets)
    ("nothing set", {}),
    ("OPENBLAS_CORETYPE=Haswell", {"OPENBLAS_CORETYPE": "Haswell"}),
    ("OPENBLAS_CORETYPE=SkylakeX", {"OPENBLAS_CORETYPE": "SkylakeX"}),
    ("OPENBLAS_CORETYPE=Zen", {"OPENBLAS_CORETYPE": "Zen"}),
    ("NPY_DISABLE_CPU_FEATURES=<AVX-512>", {"NPY_DISABLE_CPU_FEATURES": AVX512_OFF}),
    ("OPENBLAS_NUM_THREADS=2", {"OPENBLAS_NUM_THREADS": "2"}),
    ("inherit: nothing set", {"INTERLLM_NUMERICS": "inherit"}),
    ("inherit: OPENBLAS_CORETYPE=SkylakeX", {"INTERLLM_NUMERICS": "inherit", "OPENBLAS_CORETYPE": "SkylakeX"}),
    ("inherit: OPENBLAS_CORETYPE=Haswell + AVX-512 off",
     {"INTERLLM_NUMERICS": "inherit", "OPENBLAS_CORETYPE": "Haswell", "NPY_DISABLE_CPU_FEATURES": AVX512_OFF}),
]
PINNED = ("OPENBLAS_CORETYPE", "OPENBLAS_NUM_THREADS", "NPY_DISABLE_CPU_FEATURES", "INTERLLM_NUMERICS")


def kernels(env: dict) -> str:
    code = "import interllm.numerics as n; print(n.summary())"
    r = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    return (r.stdout.strip() or r.stderr.strip().splitlines()[-1])[:110]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", nargs="*", help="run only settings whose label contains one of these")
    args = ap.parse_args()
    base = {k: v for k, v in os.environ.items() if k not in PINNED}
    base["INTERLLM_PROGRESS"] = "0"
    test = "tests/test_reproduce.py::test_committed_metrics_reproduce_from_the_committed_cache"
    print(f"CPU: {interllm.numerics.cpu_model()}; SIMD flags: "
          f"{' '.join(sorted(f for f in interllm.numerics.cpu_flags() if f in interllm.numerics.SIMD_FLAGS))}")
    print(f"{'caller sets':48s} {'reproduces':>10s} {'time [s]':>9s}  kernels in effect")
    for label, extra in SETTINGS:
        if args.only and not any(o in label for o in args.only):
            continue
        env = {**base, **extra}
        t0 = time.perf_counter()
        r = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", test], cwd=ROOT,
                           env=env, capture_output=True, text=True, timeout=1800)
        dt = time.perf_counter() - t0
        approx = "not byte-identical where the numerics cannot be pinned" in r.stdout
        verdict = "NO" if r.returncode else ("approx" if approx else "yes")
        print(f"{label:48s} {verdict:>10s} {dt:9.1f}  {kernels(env)}", flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
