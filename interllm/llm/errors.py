"""Errors of the LLM layer: a backend that failed, an answer that stayed invalid, a model whose
answers fail too often to be worth an experiment."""

from __future__ import annotations

from interllm.errors import UserError


class LLMError(UserError, RuntimeError):
    """The backend failed, or its output stayed invalid after the repair retries."""


class LLMOutputError(LLMError):
    """The answer did not parse / satisfy the schema after ``llm.repair_retries`` re-asks."""

    def __init__(self, msg: str, errors: tuple[str, ...] = (), text: str = "") -> None:
        super().__init__(msg)
        self.errors = errors
        self.text = text

    def __reduce__(self):  # picklable from a worker process with its extra fields
        return (type(self), (str(self), self.errors, self.text))


class LLMQualityError(LLMError):
    """Too large a share of a backend's answers failed or did not parse (``llm.max_failure_share``):
    the model or server is broken, and an experiment on its answers would measure nothing."""
