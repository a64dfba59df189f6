"""How far a cold run's LLM time is from its token floor (issue #39, item 3).

    .venv/bin/python benchmarks/bench_token_floor.py                   # the quick experiment
    .venv/bin/python benchmarks/bench_token_floor.py experiment=paper  # any Hydra overrides

Runs the scenes, candidates and missions stages into a temporary folder with an empty LLM cache
(so the embedded model answers every call) and reads the call logs (``llm_calls.jsonl``) of the two
LLM stages. Per stage and purpose it prints the calls, the prompt tokens sent, those served from the
KV prefix cache (reused) and those evaluated (sent − reused; calibration prompts memoised within
the process count as sent and evaluated, so this is an upper bound), the seconds the calls took
(wall, cold) and the floor: evaluated tokens ÷ the prompt tokens/s this CPU reaches at the
configured threads, measured in the same process on a cold context. The ratio seconds ÷ floor is
how far each phase is from evaluating each prompt token once at full speed; its remainder is
generation, scoring the continuations, and overhead.
"""

from __future__ import annotations

# isort: off
import interllm  # noqa: F401  (first: pins BLAS and SIMD before numpy loads; interllm/numerics.py)
# isort: on

import collections
import json
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from omegaconf import OmegaConf  # noqa: E402

from interllm.llm.embedded import EmbeddedBackend  # noqa: E402
from interllm.stages.candidates import run_candidates  # noqa: E402
from interllm.stages.missions import run_missions  # noqa: E402
from interllm.stages.scenes import run_scenes  # noqa: E402
from pipeline._hydra import compose  # noqa: E402

PROBE_TOKENS = 1024  # prompt length of the speed probe [tokens], about one cost-inference prompt


def prompt_speed(cfg) -> float:
    """Prompt tokens/s of the embedded model at ``cfg.llm``'s threads, cold context, best of 3."""
    be = EmbeddedBackend(cfg.llm)
    words = " ".join(f"kitchen_counter_{i} holds bread_{i} and mug_{i}." for i in range(400))
    toks = be.tokenize(words)[:PROBE_TOKENS]
    best = 0.0
    for _ in range(3):
        be.llm.reset()
        be._aligned = 0
        t0 = time.perf_counter()
        be._prefill(toks)
        best = max(best, len(toks) / (time.perf_counter() - t0))
    be.close()
    return best


def phases(paths: list[Path]) -> dict[tuple[str, str], dict[str, float]]:
    """{(stage, purpose): {calls, sent, reused, seconds}} of the answered calls in the call logs."""
    out: dict[tuple[str, str], dict[str, float]] = collections.defaultdict(lambda: collections.Counter())
    for p in paths:
        for line in p.read_text().splitlines():
            c = json.loads(line)
            if c.get("cache_hit") or c.get("error"):
                continue
            d = out[(str(c.get("stage")), str(c.get("purpose")))]
            d["calls"] += 1
            d["sent"] += int(c.get("tokens_in", 0))
            d["reused"] += int(c.get("prompt_tokens_reused", 0))
            d["seconds"] += float(c.get("latency", 0.0))
    return out


def main(argv: list[str]) -> None:
    cfg = OmegaConf.to_object(compose(argv or ["experiment=quick"]))
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        cfg.llm.cache_dir = str(out / "cache")
        run_scenes(cfg, out / "scenes")
        t0 = time.perf_counter()
        run_candidates(cfg, out / "scenes", out / "candidates")
        run_missions(cfg, out / "scenes", out / "candidates", out / "runs")
        wall = time.perf_counter() - t0
        got = phases([out / "candidates" / "llm_calls.jsonl", out / "runs" / "llm_calls.jsonl"])
    tps = prompt_speed(cfg)
    print(f"prompt eval: {tps:.0f} tokens/s ({cfg.llm.n_threads} threads, {PROBE_TOKENS}-token cold prompt, best of 3)")
    print(f"{'stage':<11} {'purpose':<24} {'calls':>6} {'sent':>9} {'reused':>9} {'evaluated':>9} "
          f"{'seconds':>8} {'floor s':>8} {'s/floor':>7}")
    total = collections.Counter()
    for (stage, purpose), d in sorted(got.items(), key=lambda kv: -kv[1]["seconds"]):
        ev = d["sent"] - d["reused"]
        total.update({**d, "evaluated": ev})
        print(f"{stage:<11} {purpose:<24} {d['calls']:>6.0f} {d['sent']:>9.0f} {d['reused']:>9.0f} {ev:>9.0f} "
              f"{d['seconds']:>8.1f} {ev / tps:>8.1f} {d['seconds'] / max(ev / tps, 1e-9):>7.2f}")
    ev = total["evaluated"]
    print(f"{'all':<36} {total['calls']:>6.0f} {total['sent']:>9.0f} {total['reused']:>9.0f} {ev:>9.0f} "
          f"{total['seconds']:>8.1f} {ev / tps:>8.1f} {total['seconds'] / max(ev / tps, 1e-9):>7.2f}")
    print(f"reused share of the prompt tokens: {total['reused'] / max(total['sent'], 1):.1%}; "
          f"candidates + missions stages: {wall:.1f} s wall, of which LLM calls {total['seconds']:.1f} s")


if __name__ == "__main__":
    main(sys.argv[1:])
