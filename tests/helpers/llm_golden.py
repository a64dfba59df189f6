"""The embedded model's answers to a few fixed requests, computed cold (no cache): the golden file
``tests/golden/llm_embedded.json`` that ``tests/test_llm_golden.py`` compares bit for bit.

The answers depend on the llama.cpp build (its SIMD kernels round differently), so the file also
records the build that made it. Regenerate it only on purpose (a new llama-cpp-python pin, a new
baseline), on the pinned build (``make install``), and commit it with the results it moves:

    .venv/bin/python tests/helpers/llm_golden.py
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

GOLDEN = Path(__file__).resolve().parents[1] / "golden" / "llm_embedded.json"

_ROOMS = "; ".join(f"room {i}: a table, a shelf, a sofa and a chair" for i in range(6))
SCORE_CASES = [  # (prompt, continuations): a short prompt, one over several 64-token chunks, two groups
    ("Task: set up an online meeting.\nUseful item:", [" laptop", " banana", " cell phone"]),
    (f"House: {_ROOMS}.\nCommand: bring something to read to the sofa.\nThe object to pick up:",
     [" book", " newspaper", " mug", " remote control", " pillow"]),
    ("Command: prepare breakfast.\nThe furniture to put it on:",
     [f" {f} {i}" for i in range(20) for f in ("dining table", "kitchen counter")]),
]
GENERATE_SCHEMA = {"type": "object", "properties": {
    "objects": {"type": "array", "items": {"type": "string", "enum": ["cup", "laptop", "book", "bread"]},
                "minItems": 1, "maxItems": 3}}, "required": ["objects"]}
GENERATE_SEED, GENERATE_TEMPERATURE, GENERATE_MAX_TOKENS = 5, 0.8, 48


def compute() -> dict:
    """Ask a fresh embedded backend (no cache, nothing evaluated before) every golden request."""
    from interllm import llama_build
    from interllm.config import LLMConfig
    from interllm.llm.embedded import EmbeddedBackend
    from interllm.llm.types import LLMOptions, Message

    backend = EmbeddedBackend(LLMConfig(n_ctx=1024, n_threads=1))
    try:
        scores = []
        for prompt, conts in SCORE_CASES:
            raw = backend.score(prompt, conts).raw
            scores.append({"prompt": prompt, "continuations": conts, "mean_logprob": raw,
                           "mean_logprob_hex": [x.hex() for x in raw]})
        msgs = (Message("system", f"You choose objects for a household robot. Scene: {_ROOMS}."),
                Message("user", "Command: prepare breakfast. Which objects? Answer in JSON."))
        gen = backend.generate(msgs, GENERATE_SCHEMA, LLMOptions(max_tokens=GENERATE_MAX_TOKENS,
                                                                   temperature=GENERATE_TEMPERATURE),
                               seed=GENERATE_SEED)
        build = llama_build.describe()
        return {"model_sha256": backend.model_id(),
                "build": {k: build.get(k) for k in ("kind", "simd_features", "cmake_args", "system_info")},
                "score": scores,
                "generate": {"seed": GENERATE_SEED, "temperature": GENERATE_TEMPERATURE, "text": gen.text,
                             "tokens_out": gen.tokens_out}}
    finally:
        backend.close()


if __name__ == "__main__":
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))
    GOLDEN.parent.mkdir(exist_ok=True)
    GOLDEN.write_text(json.dumps(compute(), indent=1, sort_keys=True) + "\n", encoding="utf-8")
    print(f"wrote {GOLDEN}")
