"""Local LLM layer: one cached, logged client over an embedded llama.cpp model or Ollama.

    from interllm.llm import make_client, LLMRequest, Message
    client = make_client(cfg.llm, call_log_path="data/runs/llm_calls.jsonl", context={"stage": "candidates"})
    resp = client.with_context(planner="inter_llm", mission="m0").complete(
        LLMRequest(purpose="candidates", messages=(Message("user", "..."),), schema={...},
                   options=client.default_options(sample_index=j, seed=planning_seed(base, "candidates", j))))
"""

from interllm.llm.cache import CacheMissError, ResponseCache, cache_key
from interllm.llm.calllog import CallLog
from interllm.llm.client import (
    ClientStats,
    DeterministicBackend,
    LLMClient,
    LLMError,
    LLMOutputError,
    check_answer,
    make_backend,
    make_client,
    schema_instance,
)
from interllm.llm.prompts import Template, TemplateError, load_template, template_names
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
    "CacheMissError", "CallLog", "ClientStats", "DeterministicBackend", "LLMClient", "LLMClientProtocol",
    "LLMError", "LLMOptions", "LLMOutputError", "LLMRequest", "LLMResponse", "Message", "ResponseCache",
    "ScoreRequest", "ScoreResponse", "Template", "TemplateError", "cache_key", "check_answer",
    "load_template", "make_backend", "make_client", "schema_instance", "template_names",
]
