"""LLM layer: one cached, logged client over a backend (embedded llama.cpp, Ollama, any
OpenAI-compatible server, or the ground-truth oracle).

    from interllm.llm import make_client, LLMRequest, Message
    client = make_client(cfg.llm, call_log_path="data/runs/llm_calls.jsonl", context={"stage": "candidates"})
    resp = client.with_context(planner="inter_llm", mission="m0").complete(
        LLMRequest(purpose="candidates", messages=(Message("user", "..."),), schema={...},
                   options=client.default_options(sample_index=j, seed=planning_seed(base, "candidates", j))))

Modules: ``types`` (requests and responses), ``backend`` (the Backend protocol and factory),
``client`` (cache + call log + schema repair), ``client_state`` (counters, failure share and model
pin shared by a client's views), ``cache``, ``calllog``, ``schema``, ``health`` (failure share),
``deadline``, ``retry`` (Retry-After and backoff within the deadline), ``redact`` (keys out of
quoted server text), ``entry_layout`` (the cached responses' layouts), ``prompts``, ``errors``;
backends ``embedded`` (with ``model_files``, the GGUF, and ``llama_internals``, the llama-cpp-python
internals it needs and their start-up check),
``ollama_backend``, ``openai_backend`` and ``oracle_backend``; ``testing`` holds a deterministic
test backend (never imported here).
"""

from interllm.llm import embedded, ollama_backend, openai_backend, oracle_backend  # noqa: F401  (each registers its backend)
from interllm.llm.backend import BACKENDS, Backend, Generation, Scores, make_backend, preflight
from interllm.llm.cache import CacheMissError, ResponseCache, cache_key
from interllm.llm.calllog import CallLog
from interllm.llm.client import LLMClient, make_client
from interllm.llm.client_state import ClientStats
from interllm.llm.errors import LLMError, LLMOutputError, LLMQualityError
from interllm.llm.prompts import Template, TemplateError, load_template, template_names
from interllm.llm.schema import check_answer
from interllm.llm.types import (
    LLMClientProtocol,
    LLMOptions,
    LLMRequest,
    LLMResponse,
    Message,
    ScoreRequest,
    ScoreResponse,
)

__all__ = [
    "BACKENDS", "Backend", "CacheMissError", "CallLog", "ClientStats", "Generation", "LLMClient", "LLMClientProtocol",
    "LLMError", "LLMOptions", "LLMOutputError", "LLMQualityError", "LLMRequest", "LLMResponse", "Message",
    "ResponseCache", "ScoreRequest", "ScoreResponse", "Scores", "Template", "TemplateError", "cache_key",
    "check_answer", "load_template", "make_backend", "make_client", "preflight", "template_names",
]
