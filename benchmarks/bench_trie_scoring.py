"""Scoring continuations through the embedded backend's prefix trie against one sequence per
continuation, the layout before it (issue #39 item 3; adopted in issue #56): time, decoded rows, and
how far the scores move.

    .venv/bin/python benchmarks/bench_trie_scoring.py                  # 200 requests of data/llm_cache
    .venv/bin/python benchmarks/bench_trie_scoring.py --requests 40 --cache /tmp/run/cache

The backend (``EmbeddedBackend._score_trie``) decodes every distinct prefix of a group's
continuations once, in one batch whose shared tokens belong to several sequences (llama.cpp's
``n_seq_id`` > 1), and reads each continuation's log-probs from its prefixes' rows. The alternative
(``_score_sequences``) decodes each continuation as a sequence of its own over the prompt's cells:
``[last prompt token] + continuation[:-1]``, one logits row per token, so shared prefixes
(``bread_1``, ``bread_2``) and the last prompt token are decoded once per continuation. Both run on
the same prompt cells and the same groups (``score_groups``). Requests are score requests of a
cache folder (every one the default run made is in the committed ``data/llm_cache``), shuffled with
a fixed seed. Printed: the seconds of continuation decoding each way, rows decoded, the scores that
differ and by how much, and the requests whose best continuation changes; and how far each way is
from scoring every continuation alone (a group of one, the layout with nothing beside it).
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
from interllm.llm.embedded import SCORE_SEQS, EmbeddedBackend, prefix_trie, score_groups  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent


def both(be: EmbeddedBackend, prompt: str, texts: list[str]) -> dict:
    """The trie's (the backend's) and the one-sequence-each scores of one request, with seconds and
    rows of each, and each continuation scored alone."""
    conts = [be.tokenize(c, bos=False) for c in texts]
    toks = be.tokenize(prompt)
    be._start_call("benchmark")
    be._prefill(toks[:-1])
    groups = score_groups([len(c) for c in conts], SCORE_SEQS, be.llm.n_batch)
    t0 = time.perf_counter()
    seq = [s for g in groups for s in be._score_sequences(toks[-1], conts, g)]
    t1 = time.perf_counter()
    trie = [s for g in groups for s in be._score_trie(toks[-1], conts, g)]
    t2 = time.perf_counter()
    alone = [be._score_sequences(toks[-1], conts, range(k, k + 1))[0] for k in range(len(conts))]
    return {"seq": seq, "trie": trie, "alone": alone, "t_seq": t1 - t0, "t_trie": t2 - t1,
            "rows_seq": sum(len(c) for c in conts), "rows_trie": sum(len(prefix_trie(conts, g)) for g in groups)}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--cache", type=Path, default=ROOT / "data" / "llm_cache", help="an LLM cache folder")
    ap.add_argument("--requests", type=int, default=200, help="score requests to replay")
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args()
    be = EmbeddedBackend(LLMConfig(n_threads=args.threads))
    _ = be.llm  # loads the model; multi_sequence is known from then on
    if not be.multi_sequence:
        raise SystemExit("this llama-cpp-python build has no multi-sequence context; nothing to compare")
    files = sorted(args.cache.rglob("*.json"))
    random.Random(0).shuffle(files)
    tot = {"t_seq": 0.0, "t_trie": 0.0, "rows_seq": 0, "rows_trie": 0}
    n = scores = differ = flips = 0
    worst = 0.0
    from_alone = {"seq": [], "trie": []}  # |score - the continuation scored alone| [nats]
    best_as_alone = {"seq": 0, "trie": 0}  # requests whose best continuation is the one alone picks
    for f in files:
        request = json.loads(f.read_text()).get("request") or {}
        if "continuations" not in request:
            continue
        r = both(be, request["prompt"], request["continuations"])
        for k in tot:
            tot[k] += r[k]
        d = [abs(a - b) for a, b in zip(r["seq"], r["trie"], strict=True)]
        scores, differ, worst = scores + len(d), differ + sum(x > 0 for x in d), max([worst, *d])
        flips += int(np.argmax(r["seq"]) != np.argmax(r["trie"]))
        for way in from_alone:
            from_alone[way] += [abs(a - b) for a, b in zip(r[way], r["alone"], strict=True)]
            best_as_alone[way] += int(np.argmax(r[way]) == np.argmax(r["alone"]))
        n += 1
        if n >= args.requests:
            break
    print(f"{n} score requests of {args.cache}, {scores} continuations, {args.threads} threads")
    print(f"{'decode':<26}{'seconds':>9}{'rows':>8}")
    print(f"{'one sequence each':<26}{tot['t_seq']:>9.1f}{tot['rows_seq']:>8}")
    print(f"{'prefix trie (the backend)':<26}{tot['t_trie']:>9.1f}{tot['rows_trie']:>8}")
    print(f"trie / one sequence each: {tot['t_trie'] / max(tot['t_seq'], 1e-9):.2f} of the seconds, "
          f"{tot['rows_trie'] / max(tot['rows_seq'], 1):.2f} of the rows")
    print(f"scores that differ: {differ} of {scores}, by up to {worst:.3g} nats; "
          f"requests whose best continuation changes: {flips} of {n}")
    print("against scoring each continuation alone (a group of one):")
    for way, label in (("seq", "one sequence each"), ("trie", "prefix trie (the backend)")):
        d = np.asarray(from_alone[way])
        print(f"  {label:<24} mean |diff| {d.mean():.4f} nats, max {d.max():.3f}; "
              f"same best continuation in {best_as_alone[way]} of {n} requests")


if __name__ == "__main__":
    main()
