"""Scoring continuations through a prefix trie against the embedded backend's decode (issue #39,
item 3): time, decoded rows, and how far the scores move.

    .venv/bin/python benchmarks/bench_trie_scoring.py                  # 200 requests of data/llm_cache
    .venv/bin/python benchmarks/bench_trie_scoring.py --requests 40 --cache /tmp/run/cache

The backend (``EmbeddedBackend._score_group``) decodes each continuation as a sequence of its own
over the prompt's cells: ``[last prompt token] + continuation[:-1]``, one logits row per token, so
shared prefixes (``bread_1``, ``bread_2``) and the last prompt token are decoded once per
continuation. The alternative decodes every distinct prefix once, in one batch whose shared tokens
belong to several sequences (llama.cpp's ``n_seq_id`` > 1), and reads each continuation's
log-probs from its prefixes' rows. Both run on the same prompt cells and the same groups
(``score_groups``). Requests are score requests of a cache folder (every one the default run made
is in the committed ``data/llm_cache``), shuffled with a fixed seed. Printed: the seconds of
continuation decoding each way, rows decoded, the scores that differ and by how much, and the
requests whose best continuation changes; and how far each way is from scoring every continuation
alone (a group of one, the layout with nothing beside it).
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
from interllm.llm.embedded import SCORE_SEQS, EmbeddedBackend, _log_softmax_at, score_groups  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent


class TrieScorer:
    """Mean log-probs of continuations decoded as a prefix trie (module docstring)."""

    def __init__(self, backend: EmbeddedBackend) -> None:
        from llama_cpp import llama_cpp as bindings  # lazy: loads the llama.cpp library

        self.be, self.b = backend, bindings
        self.batch = bindings.llama_batch_init(backend.llm.n_batch, 0, SCORE_SEQS + 1)

    def group(self, last: int, conts: list[list[int]], group: range) -> tuple[list[float], int]:
        llm, b = self.be.llm, self.b
        n_past, mem = llm.n_tokens, llm._ctx.memory
        rows: dict[tuple[int, ...], int] = {}  # prefix -> batch row
        members: dict[tuple[int, ...], list[int]] = {}  # prefix -> sequence ids through it
        for sid, k in enumerate(group, start=1):
            b.llama_memory_seq_cp(mem, 0, sid, 0, n_past)
            for i in range(len(conts[k])):
                prefix = tuple(conts[k][:i])
                rows.setdefault(prefix, len(rows))
                members.setdefault(prefix, []).append(sid)
        batch = self.batch
        batch.n_tokens = 0
        for prefix, j in rows.items():
            batch.token[j] = prefix[-1] if prefix else last
            batch.pos[j], batch.n_seq_id[j], batch.logits[j] = n_past + len(prefix), len(members[prefix]), True
            for q, sid in enumerate(members[prefix]):
                batch.seq_id[j][q] = sid
            batch.n_tokens += 1
        try:
            if b.llama_decode(llm._ctx.ctx, batch) != 0:
                raise RuntimeError("llama_decode failed on the trie batch")
            nv = llm.n_vocab()
            logits = np.ctypeslib.as_array(b.llama_get_logits(llm._ctx.ctx), shape=(len(rows) * nv,)).reshape(-1, nv)
            out = []
            for k in group:
                lp = _log_softmax_at(logits[[rows[tuple(conts[k][:i])] for i in range(len(conts[k]))]], conts[k])
                out.append(sum(float(x) for x in lp) / len(lp))
            return out, len(rows)
        finally:
            for sid in range(1, len(group) + 1):
                b.llama_memory_seq_rm(mem, sid, -1, -1)


def both(be: EmbeddedBackend, trie: TrieScorer, prompt: str, texts: list[str]) -> dict:
    """The backend's and the trie's scores of one request, with seconds and rows of each."""
    conts = [be.tokenize(c, bos=False) for c in texts]
    toks = be.tokenize(prompt)
    be._start_call("benchmark")
    be._prefill(toks[:-1])
    groups = score_groups([len(c) for c in conts], SCORE_SEQS, be.llm.n_batch)
    t0 = time.perf_counter()
    seq = [s for g in groups for s in be._score_group(toks[-1], conts, g)]
    t1 = time.perf_counter()
    got = [trie.group(toks[-1], conts, g) for g in groups]
    t2 = time.perf_counter()
    alone = [be._score_group(toks[-1], conts, range(k, k + 1))[0] for k in range(len(conts))]
    return {"seq": seq, "trie": [s for g, _ in got for s in g], "alone": alone, "t_seq": t1 - t0,
            "t_trie": t2 - t1, "rows_seq": sum(len(c) for c in conts), "rows_trie": sum(n for _, n in got)}


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
    trie = TrieScorer(be)
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
        r = both(be, trie, request["prompt"], request["continuations"])
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
    print(f"{'one sequence each (now)':<26}{tot['t_seq']:>9.1f}{tot['rows_seq']:>8}")
    print(f"{'prefix trie':<26}{tot['t_trie']:>9.1f}{tot['rows_trie']:>8}")
    print(f"trie / now: {tot['t_trie'] / max(tot['t_seq'], 1e-9):.2f} of the seconds, "
          f"{tot['rows_trie'] / max(tot['rows_seq'], 1):.2f} of the rows")
    print(f"scores that differ: {differ} of {scores}, by up to {worst:.3g} nats; "
          f"requests whose best continuation changes: {flips} of {n}")
    print("against scoring each continuation alone (a group of one):")
    for way, label in (("seq", "one sequence each (now)"), ("trie", "prefix trie")):
        d = np.asarray(from_alone[way])
        print(f"  {label:<24} mean |diff| {d.mean():.4f} nats, max {d.max():.3f}; "
              f"same best continuation in {best_as_alone[way]} of {n} requests")


if __name__ == "__main__":
    main()
