"""``llm.backend=oracle``: the name under which the ground-truth input source (``llm=oracle``,
:mod:`interllm.planning.oracle`) runs through the pipeline. It is not a model: the oracle's
proposal and cost modes answer without asking a backend, so no request ever reaches this one
(one that does is a bug and fails loudly), and nothing is cached or logged as an LLM call."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Optional

from interllm.config import LLMConfig
from interllm.llm.backend import BACKENDS, Generation, Scores
from interllm.llm.types import LLMOptions, Message


@BACKENDS.register("oracle", label="oracle (ground truth)")
class OracleBackend:
    name = "oracle"

    def __init__(self, cfg: LLMConfig) -> None:
        self.cfg = cfg

    def model_name(self) -> str:
        return "oracle"

    def model_id(self) -> str:
        return f"oracle-error-{self.cfg.oracle_error:g}"

    def check(self) -> None:
        """Nothing to reach: the oracle reads the scene graph and the simulator."""

    def _refuse(self, what: str):
        raise RuntimeError(f"llm.backend=oracle got a {what} request; the oracle's proposal and cost modes "
                           f"answer without a model (llm.proposal_mode and llm.cost_inference_mode must be 'oracle')")

    def generate(self, messages: Sequence[Message], schema: Optional[dict], options: LLMOptions,
                 seed: int) -> Generation:
        self._refuse("generation")

    def score(self, prompt: str, continuations: Sequence[str], calibration_prompt: Optional[str] = None) -> Scores:
        self._refuse("scoring")

    def close(self) -> None:
        pass
