"""Request/response types of the one LLM client API every planner and stage uses."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Optional, Protocol


@dataclass(frozen=True)
class Message:
    role: str  # "system" | "user" | "assistant"
    content: str


@dataclass(frozen=True)
class LLMOptions:
    temperature: float = 0.8
    seed: int = 0
    top_p: float = 0.95
    max_tokens: int = 384
    sample_index: int = 0  # candidate j of M: part of the cache key and of the derived seed


@dataclass(frozen=True)
class LLMRequest:
    """Generation: messages + optional JSON schema for structured output + options."""

    purpose: str  # "candidates" | "regeneration" | "cost_inference" | "replan" | ...
    messages: tuple[Message, ...]
    schema: Optional[dict] = None  # JSON Schema the answer must satisfy
    options: LLMOptions = field(default_factory=LLMOptions)
    template: str = ""  # prompt template name; its hash goes into the cache key
    context: tuple[tuple[str, str], ...] = ()  # call-log labels: (("planner", ...), ("mission", ...))


@dataclass
class LLMResponse:
    text: str
    parsed: Any  # parsed JSON (schema-valid) or None when no schema
    tokens_in: int
    tokens_out: int
    latency: float  # [s] wall time of the backend call (0 on a cache hit); never used in metrics
    cached: bool
    key: str  # cache key (sha256 hex)
    prompt_tokens_reused: int = 0  # prompt tokens served from the backend's KV prefix cache
    errors: tuple[str, ...] = ()  # parse/schema errors repaired along the way


@dataclass(frozen=True)
class ScoreRequest:
    """Scoring: log-likelihood of each continuation after one prompt (SayCan-style).

    With ``calibration_prompt`` the score is log p(cont | prompt) − log p(cont | calibration),
    which removes the model's prior for each continuation.
    """

    purpose: str
    prompt: str
    continuations: tuple[str, ...]
    calibration_prompt: Optional[str] = None
    template: str = ""
    context: tuple[tuple[str, str], ...] = ()


@dataclass
class ScoreResponse:
    scores: list[float]  # one per continuation: mean token log-prob (calibrated if asked)
    raw: list[float]  # uncalibrated mean token log-prob
    tokens_in: int
    latency: float
    cached: bool
    key: str
    prompt_tokens_reused: int = 0


class LLMClientProtocol(Protocol):
    """What planners and proposers need of a client (``interllm.llm.client.LLMClient``)."""

    def complete(self, request: LLMRequest) -> LLMResponse: ...

    def score(self, request: ScoreRequest) -> ScoreResponse: ...

    def with_context(self, **labels: Any) -> LLMClientProtocol: ...

    def with_observer(self, observer: Callable[[Any, Any], None]) -> LLMClientProtocol: ...
