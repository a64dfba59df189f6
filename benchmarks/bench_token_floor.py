"""How far a cold run's LLM time is from its token floor (issue #39, item 3).

    .venv/bin/python benchmarks/bench_token_floor.py                   # the quick experiment
    .venv/bin/python benchmarks/bench_token_floor.py experiment=paper  # any Hydra overrides
    .venv/bin/python benchmarks/bench_token_floor.py --out /tmp/run    # keep the run's folder

Runs the scenes, candidates and missions stages in this process (``jobs=1``) into a temporary
folder with an empty LLM cache, so the embedded model answers every call. The backend's prompt
evaluation and continuation decoding are wrapped to count the tokens the model really evaluates;
each call's count is attributed to the call the client logs next (so the candidates stage's
unlogged preflight probe counts with that stage's first call). Per stage and purpose it prints
the calls, the tokens sent (the call log's ``tokens_in``: prompt, calibration prompt and
continuations), those served from the KV prefix cache (reused), those evaluated (prompt tokens not
reused, calibration prompts not memoised, continuation tokens), those of the evaluated prompt tokens
whose whole prefix this process had evaluated before (again: the most that keeping earlier prompts'
KV cells, not only the last prompt's, could save), the seconds the calls took (wall,
cold) and the floor: evaluated tokens ÷ the prompt tokens/s this CPU reaches at llm.n_threads,
measured on a cold context. The ratio seconds ÷ floor is
how far each phase is from evaluating each prompt token once at full speed; its remainder is
generation, scoring the continuations, and overhead.
"""

from __future__ import annotations

# isort: off
import interllm  # noqa: F401  (first: pins BLAS and SIMD before numpy loads; interllm/numerics.py)
# isort: on

import collections
import dataclasses
import hashlib
import json
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import numpy as np  # noqa: E402
from _usage import overrides  # noqa: E402  (benchmarks/_usage.py, beside this script)
from omegaconf import OmegaConf  # noqa: E402

from interllm.llm.client import LLMClient  # noqa: E402
from interllm.llm.embedded import CHUNK, EmbeddedBackend  # noqa: E402
from interllm.stages.candidates import run_candidates  # noqa: E402
from interllm.stages.missions import run_missions  # noqa: E402
from interllm.stages.scenes import run_scenes  # noqa: E402
from pipeline._hydra import compose  # noqa: E402

PROBE_TOKENS = 1024  # prompt length of the speed probe [tokens], about one cost-inference prompt


def prompt_speed(cfg, threads: int) -> float:
    """Prompt tokens/s of the embedded model at ``threads`` threads, cold context, best of 3."""
    be = EmbeddedBackend(dataclasses.replace(cfg.llm, n_threads=threads))
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


EVALUATED = [0]  # tokens the model evaluated since the client last logged a call
AGAIN = [0]  # of those, prompt tokens whose whole prefix this process had evaluated before
PER_CALL: list[tuple[int, int]] = []  # (evaluated, evaluated again) of each logged call, in call-log order
SEEN: set[bytes] = set()  # digests of every prompt prefix evaluated so far, per chunk end


def count_again(want: list[int], keep: int) -> int:
    """Prompt tokens of ``want`` evaluated from position ``keep`` on (in aligned CHUNK-token chunks, as
    the backend evaluates them) whose whole prefix up to the chunk's end this process had evaluated
    before: what a store of earlier prompts' KV cells, not only the context's last prompt, could have
    served. Only whole aligned chunks count (the backend reuses nothing else)."""
    if keep >= len(want):
        return 0
    ends = [*range((keep // CHUNK + 1) * CHUNK, len(want), CHUNK), len(want)]
    h = hashlib.blake2b(digest_size=16)  # a running digest of want[:end]
    h.update(np.asarray(want[:keep], dtype=np.int32).tobytes())
    again, start = 0, keep
    for end in ends:
        h.update(np.asarray(want[start:end], dtype=np.int32).tobytes())
        digest = h.copy().digest()
        if digest in SEEN and end % CHUNK == 0:
            again += end - start
        SEEN.add(digest)
        start = end
    return again


def count_evaluated() -> None:
    """Wrap the embedded backend's prompt evaluation and continuation decoding, and the client's call
    log, so every logged call carries the tokens the model evaluated for it (``PER_CALL``)."""
    prefill, group, log = EmbeddedBackend._prefill, EmbeddedBackend._score_group, LLMClient._log

    def _prefill(self, want):
        keep = prefill(self, want)
        EVALUATED[0] += len(want) - keep
        AGAIN[0] += count_again(want, keep)
        return keep

    def _score_group(self, last, conts, grp):
        EVALUATED[0] += sum(len(conts[k]) for k in grp)
        return group(self, last, conts, grp)

    def _log(self, **kw):
        PER_CALL.append((EVALUATED[0], AGAIN[0]))
        EVALUATED[0] = AGAIN[0] = 0
        return log(self, **kw)

    EmbeddedBackend._prefill, EmbeddedBackend._score_group, LLMClient._log = _prefill, _score_group, _log


def phases(paths: list[Path], per_call: list[int]) -> dict[tuple[str, str], dict[str, float]]:
    """{(stage, purpose): {calls, sent, reused, evaluated, again, seconds}} of the answered calls in the
    call logs (``paths`` in the order they were written; ``per_call``: each logged call's evaluated
    tokens and those of them evaluated before, ``count_again``)."""
    out: dict[tuple[str, str], dict[str, float]] = collections.defaultdict(lambda: collections.Counter())
    lines = [json.loads(line) for p in paths for line in p.read_text().splitlines()]
    if len(lines) != len(per_call):
        raise SystemExit(f"{len(lines)} logged calls but {len(per_call)} counted: a call was logged elsewhere")
    for c, (ev, again) in zip(lines, per_call, strict=True):
        if c.get("cache_hit") or c.get("error"):
            continue
        d = out[(str(c.get("stage")), str(c.get("purpose")))]
        d["calls"] += 1
        d["sent"] += int(c.get("tokens_in", 0))
        d["reused"] += int(c.get("prompt_tokens_reused", 0))
        d["evaluated"] += ev if ev else int(c.get("tokens_in", 0)) - int(c.get("prompt_tokens_reused", 0))
        d["again"] += again
        d["seconds"] += float(c.get("latency", 0.0))
    return out


def main(argv: list[str]) -> None:
    keep = None
    if "--out" in argv:  # keep the run's folder (call logs, runs) there instead of a temporary one
        i = argv.index("--out")
        keep, argv = Path(argv[i + 1]), argv[:i] + argv[i + 2:]
    cfg = OmegaConf.to_object(compose(overrides(argv, __doc__) or ["experiment=quick"]))
    cfg.jobs = 1  # in this process, so the wrapped backend counts every call
    count_evaluated()
    with tempfile.TemporaryDirectory() as tmp:
        out = keep if keep is not None else Path(tmp)
        cfg.llm.cache_dir = str(out / "cache")
        run_scenes(cfg, out / "scenes")
        t0 = time.perf_counter()
        run_candidates(cfg, out / "scenes", out / "candidates")
        run_missions(cfg, out / "scenes", out / "candidates", out / "runs")
        wall = time.perf_counter() - t0
        got = phases([out / "candidates" / "llm_calls.jsonl", out / "runs" / "llm_calls.jsonl"], PER_CALL)
    threads = {"candidates": cfg.llm.n_threads, "missions": cfg.llm.n_threads}  # one process: all threads
    speed = {t: prompt_speed(cfg, t) for t in sorted(set(threads.values()) | {1})}
    for t, v in speed.items():
        print(f"prompt eval: {v:.0f} tokens/s at {t} thread(s) ({PROBE_TOKENS}-token cold prompt, best of 3)")
    print(f"{'stage':<11} {'purpose':<24} {'calls':>6} {'sent':>9} {'reused':>9} {'evaluated':>9} {'again':>8} "
          f"{'seconds':>8} {'floor s':>8} {'s/floor':>7}")
    total = collections.Counter()
    for (stage, purpose), d in sorted(got.items(), key=lambda kv: -kv[1]["seconds"]):
        ev = d["evaluated"]
        tps = speed[threads.get(stage, cfg.llm.n_threads)]
        total.update({**d, "evaluated": ev, "floor": ev / tps})
        print(f"{stage:<11} {purpose:<24} {d['calls']:>6.0f} {d['sent']:>9.0f} {d['reused']:>9.0f} {ev:>9.0f} "
              f"{d['again']:>8.0f} "
              f"{d['seconds']:>8.1f} {ev / tps:>8.1f} {d['seconds'] / max(ev / tps, 1e-9):>7.2f}")
    ev, floor = total["evaluated"], total["floor"]
    print(f"{'all':<36} {total['calls']:>6.0f} {total['sent']:>9.0f} {total['reused']:>9.0f} {ev:>9.0f} "
          f"{total['again']:>8.0f} "
          f"{total['seconds']:>8.1f} {floor:>8.1f} {total['seconds'] / max(floor, 1e-9):>7.2f}")
    print(f"reused share of the prompt tokens: {total['reused'] / max(total['sent'], 1):.1%}; "
          f"candidates + missions stages: {wall:.1f} s wall, of which LLM calls {total['seconds']:.1f} s")


if __name__ == "__main__":
    main(sys.argv[1:])
