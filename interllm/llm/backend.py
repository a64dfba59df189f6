"""What a backend is: the ``Backend`` protocol, its result types, and the factory by config.

A backend answers ``generate`` (one completion, optionally under a JSON schema) and ``score``
(log-likelihood of continuations); the client (``interllm.llm.client``) adds the cache, the call
log, schema checks and repairs. Adding one: a class ``Backend(cfg: LLMConfig)`` with the
methods below, decorated ``@BACKENDS.register("<name>")``, in a module named in ``BACKENDS``' builtins
(imported on the first lookup); ``llm.backend=<name>`` then selects it (see docs/extending.md, "Adding an LLM backend").
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Optional, Protocol

from interllm.config import LLMConfig
from interllm.llm.types import LLMOptions, Message
from interllm.registry import Registry


@dataclass
class Generation:
    text: str
    tokens_in: int
    tokens_out: int
    prompt_tokens_reused: int = 0
    truncated: bool = False  # stopped at max_tokens


@dataclass
class Scores:
    raw: list[float]  # mean token log-prob of each continuation after the prompt
    calibration: Optional[list[float]]  # the same after the calibration prompt (None if not asked)
    tokens_in: int  # tokens evaluated or reused (prompt + continuations)
    prompt_tokens_reused: int = 0
    method: str = "logprob"


class Backend(Protocol):
    name: str

    def model_name(self) -> str: ...

    def model_id(self) -> str: ...

    def generate(self, messages: Sequence[Message], schema: Optional[dict], options: LLMOptions,
                 seed: int) -> Generation: ...

    def score(self, prompt: str, continuations: Sequence[str],
              calibration_prompt: Optional[str] = None) -> Scores: ...

    def close(self) -> None: ...


# filled by @BACKENDS.register in each backend; the built-in ones are imported on the first lookup
BACKENDS: Registry = Registry("LLM backend", "llm.backend", builtins=(
    "interllm.llm.embedded", "interllm.llm.ollama_backend", "interllm.llm.openai_backend", "interllm.llm.oracle_backend"))


def make_backend(cfg: LLMConfig) -> Backend:
    """The backend named by ``cfg.backend`` (no model load or server contact yet); an unknown name
    raises ConfigError listing the registered backends."""
    return BACKENDS.get(cfg.backend)(cfg)


def preflight(cfg: LLMConfig) -> dict | None:
    """Before any stage output is written: is the backend there (server up, model present, model
    file readable, the modes' needs met)? Raises the backend's error naming the URL or file and the
    fix; returns what a backend with a conformance probe measured (else None). Nothing to check in
    replay mode, where the cache answers everything."""
    if cfg.cache_mode == "replay":
        return None
    backend = make_backend(cfg)
    try:
        check = getattr(backend, "check", None)
        if check is not None:
            check()
        probe = getattr(backend, "probe", None)
        return probe().to_dict() if probe is not None else None
    finally:
        backend.close()
