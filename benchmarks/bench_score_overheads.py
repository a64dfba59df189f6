"""What scoring spends outside the transformer, against the obvious ways to do it (issue #39).

Replays score requests of a cache folder (shuffled with a fixed seed) through one embedded backend
in two configurations, alternating request by request so machine load hits both alike:

- **now**: the backend as it is, prompt chunks decoded without a logits row
  (``llama_internals.eval_prompt``) and the log-softmax in 16-row blocks of a reused scratch;
- **plain**: prompt chunks through ``Llama.eval`` (which asks for the last token's logits row)
  and the log-softmax as one expression over the whole [rows, vocab] array.

Printed: seconds per configuration, the seconds inside the log-softmax, and whether every score
of every request is bit for bit the same both ways (it must be: the two differ only in work whose
result nobody reads, and in temporaries). The context is cleared before each request, so neither
configuration reuses the other's KV cells.

    .venv/bin/python benchmarks/bench_score_overheads.py [--requests 40] [--threads 1] [--cache DIR]
"""

from __future__ import annotations

# isort: off
import interllm  # noqa: F401  (first: pins BLAS and SIMD before numpy loads; interllm/numerics.py)
# isort: on

import argparse
import json
import random
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from interllm.config import LLMConfig  # noqa: E402
from interllm.llm import embedded, llama_internals  # noqa: E402
from interllm.llm.embedded import EmbeddedBackend  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent


def whole_array_log_softmax(logits: np.ndarray, tokens) -> np.ndarray:
    """The one-expression log-softmax: two [rows, vocab] temporaries per call."""
    m = logits.max(axis=1, keepdims=True)
    lse = np.log(np.exp(logits - m).sum(axis=1, dtype=np.float64)) + m[:, 0].astype(np.float64)
    return logits[np.arange(len(tokens)), np.asarray(tokens)].astype(np.float64) - lse


def llama_eval(llm, tokens) -> None:
    """Prompt chunks as ``Llama.eval`` decodes them: with the last token's logits row."""
    llm.eval(tokens)


class Timed:
    """Wraps a function and adds up the seconds spent in it."""

    def __init__(self, fn) -> None:
        self.fn, self.seconds = fn, 0.0

    def __call__(self, *args):
        t0 = time.perf_counter()
        try:
            return self.fn(*args)
        finally:
            self.seconds += time.perf_counter() - t0


def score_requests(cache: Path, n: int) -> list[dict]:
    files = sorted(cache.rglob("*.json"))
    random.Random(0).shuffle(files)
    out = []
    for f in files:
        request = json.loads(f.read_text()).get("request") or {}
        if request.get("backend") == "embedded" and "continuations" in request:
            out.append(request)
            if len(out) == n:
                break
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cache", type=Path, default=ROOT / "data" / "llm_cache", help="an LLM cache folder")
    ap.add_argument("--requests", type=int, default=40, help="score requests to replay")
    ap.add_argument("--threads", type=int, default=1, help="llama.cpp threads (a mission worker uses 1)")
    args = ap.parse_args()
    be = EmbeddedBackend(LLMConfig(n_threads=args.threads))
    _ = be.llm
    configs = {"now": (Timed(embedded._log_softmax_at), Timed(llama_internals.eval_prompt)),
               "plain": (Timed(whole_array_log_softmax), Timed(llama_eval))}
    wall = dict.fromkeys(configs, 0.0)
    same = True
    requests = score_requests(args.cache, args.requests)
    for request in requests:
        scores = {}
        for name, (softmax, prompt_eval) in configs.items():
            embedded._log_softmax_at, llama_internals.eval_prompt = softmax, prompt_eval
            be._calib_memo.clear()
            llama_internals.truncate(be.llm, 0)
            be._aligned = 0
            t0 = time.perf_counter()
            s = be.score(request["prompt"], request["continuations"], request.get("calibration_prompt"))
            wall[name] += time.perf_counter() - t0
            scores[name] = (s.raw, s.calibration)
        same &= scores["now"] == scores["plain"]
    print(f"{len(requests)} score requests of {args.cache}, {args.threads} thread(s), each asked both ways")
    print(f"{'configuration':<52}{'seconds':>9}{'in log-softmax':>16}")
    labels = {"now": "now (no prompt logits row, blocked log-softmax)",
              "plain": "plain (Llama.eval, whole-array log-softmax)"}
    for name, (softmax, _) in configs.items():
        print(f"{labels[name]:<52}{wall[name]:>9.1f}{softmax.seconds:>16.1f}")
    print(f"now / plain: {wall['now'] / max(wall['plain'], 1e-9):.2f} of the seconds; "
          f"scores bit for bit the same: {same}")


if __name__ == "__main__":
    main()
