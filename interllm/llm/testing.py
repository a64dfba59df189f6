"""A deterministic test backend, for code where the LLM is not under test. Never imported by the
library's runtime: tests and benchmarks import it from here."""

from __future__ import annotations

import hashlib
import random
from collections.abc import Callable, Sequence
from typing import Any, Optional

from interllm.core import jsonfmt
from interllm.core.seeding import llm_sample_seed
from interllm.llm.backend import Generation, Scores
from interllm.llm.types import LLMOptions, Message


def schema_instance(schema: dict, rng: random.Random, root: Optional[dict] = None, depth: int = 0) -> Any:
    """A value satisfying ``schema`` drawn with ``rng`` (covers the subset our prompts use:
    type object/array/string/integer/number/boolean/null, enum, const, anyOf/oneOf, local $ref,
    required, min/maxItems, uniqueItems, minimum/maximum, minLength)."""
    root = schema if root is None else root
    if depth > 20:
        raise ValueError("schema nesting too deep for schema_instance")
    if "$ref" in schema:
        ref = schema["$ref"]
        if not ref.startswith("#/"):
            raise ValueError(f"only local $ref are supported, got {ref!r}")
        node: Any = root
        for part in ref[2:].split("/"):
            node = node[part]
        return schema_instance(node, rng, root, depth + 1)
    if "const" in schema:
        return schema["const"]
    if "enum" in schema:
        return rng.choice(list(schema["enum"]))
    for k in ("anyOf", "oneOf"):
        if k in schema:
            return schema_instance(schema[k][0], rng, root, depth + 1)
    if "allOf" in schema:
        merged: dict = {}
        for s in schema["allOf"]:
            merged.update(s)
        return schema_instance(merged, rng, root, depth + 1)
    t = schema.get("type", "object" if "properties" in schema else "string")
    if isinstance(t, list):
        t = t[0]
    if t == "object":
        props = schema.get("properties", {})
        keys = list(schema.get("required", list(props)))
        return {k: schema_instance(props.get(k, {"type": "string"}), rng, root, depth + 1) for k in keys}
    if t == "array":
        lo = int(schema.get("minItems", 1))
        hi = int(schema.get("maxItems", max(lo, 3)))
        n = rng.randint(lo, max(lo, hi))
        items = schema.get("items", {"type": "string"})
        out: list = []
        tries = 0
        while len(out) < n and tries < 50 * (n + 1):
            tries += 1
            v = schema_instance(items, rng, root, depth + 1)
            if schema.get("uniqueItems") and v in out:
                continue
            out.append(v)
        return out
    if t == "integer":
        lo = int(schema.get("minimum", 0))
        return rng.randint(lo, int(schema.get("maximum", lo + 20)))
    if t == "number":
        lo = float(schema.get("minimum", 0.0))
        return round(rng.uniform(lo, float(schema.get("maximum", lo + 20.0))), 3)
    if t == "boolean":
        return rng.random() < 0.5
    if t == "null":
        return None
    n = max(int(schema.get("minLength", 1)), 1)
    return "".join(rng.choice("abcdefghijklmnopqrstuvwxyz") for _ in range(max(n, 4)))


class DeterministicBackend:
    """Test backend for code where the LLM is not under test: schema-valid JSON drawn from a
    seeded RNG (seed = the call's seed and the messages), scores from a hash of the text.

    ``generate_fn(messages, schema, options, seed) -> str`` / ``score_fn(prompt, cont) -> float``
    replace the defaults to script answers.
    """

    name = "deterministic"

    def __init__(self, generate_fn: Optional[Callable[..., str]] = None,
                 score_fn: Optional[Callable[[str, str], float]] = None, model: str = "deterministic-v1"):
        self.generate_fn = generate_fn
        self.score_fn = score_fn
        self.model = model
        self.generate_calls = 0
        self.score_calls = 0

    def model_name(self) -> str:
        return self.model

    def model_id(self) -> str:
        return hashlib.sha256(self.model.encode()).hexdigest()

    def generate(self, messages: Sequence[Message], schema: Optional[dict], options: LLMOptions,
                 seed: int) -> Generation:
        self.generate_calls += 1
        if self.generate_fn is not None:
            text = self.generate_fn(messages, schema, options, seed)
        else:
            rng = random.Random(llm_sample_seed(seed, [[m.role, m.content] for m in messages].__repr__()))
            text = jsonfmt.compact(schema_instance(schema, rng)) if schema is not None else "ok"
        tin = sum(len(m.content.split()) + 4 for m in messages)
        return Generation(text=text, tokens_in=tin, tokens_out=max(1, len(text) // 4))

    def score(self, prompt: str, continuations: Sequence[str],
              calibration_prompt: Optional[str] = None) -> Scores:
        self.score_calls += 1

        def f(p: str, c: str) -> float:
            if self.score_fn is not None:
                return float(self.score_fn(p, c))
            return -1.0 - llm_sample_seed(p, c) / 2**31 * 9.0  # in (-10, -1]

        raw = [f(prompt, c) for c in continuations]
        calib = [f(calibration_prompt, c) for c in continuations] if calibration_prompt is not None else None
        return Scores(raw=raw, calibration=calib,
                      tokens_in=len(prompt.split()) + sum(len(c.split()) for c in continuations))

    def close(self) -> None:
        pass
