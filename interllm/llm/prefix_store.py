"""Earlier prompts' KV cells, kept so that a later prompt sharing their beginning need not evaluate
it again.

The embedded model's context holds one prompt; the next prompt reuses the aligned chunks it shares
with that one and evaluates the rest. Requests of different kinds alternate (object scores, then
cost inferences, then object scores of the next command...), so a long shared beginning — the
known costs a mission's cost inferences all start with, a house description — is evaluated again
each time another kind of request ran in between. :class:`PrefixStore` keeps the KV cells of the
last prompts' aligned prefixes (llama.cpp's serialisation of sequence 0, about 18 KB per token for
Gemma 3 270M) up to a byte budget, least recently used out, and names the one that shares the
longest aligned prefix with a new prompt.

Results do not change: the embedded backend evaluates every prompt in chunks aligned to absolute
positions, so the cells of a prefix are the same bits however it came into the context (restored
here, kept from the last prompt or evaluated now), and only an entry the new prompt begins
with whole is restored.
"""

from __future__ import annotations

from collections import OrderedDict
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np


@dataclass(frozen=True)
class StoredPrefix:
    tokens: np.ndarray  # the prefix's tokens (int32), a whole number of chunks
    data: Any  # llama.cpp's serialisation of its KV cells, a byte buffer (llama_internals.save_sequence)


class PrefixStore:
    """Aligned prompt prefixes and their KV cells, at most ``max_bytes`` of cells in all.

    chunk: the evaluation chunk [tokens]; only whole chunks are stored and matched.
    """

    def __init__(self, max_bytes: int, chunk: int) -> None:
        self.max_bytes, self.chunk = int(max_bytes), int(chunk)
        self._entries: OrderedDict[bytes, StoredPrefix] = OrderedDict()  # least recently used first
        self.bytes = 0  # [bytes] of cells held
        self.restored_tokens = 0  # prompt tokens served from the store (diagnostics)

    def __len__(self) -> int:
        return len(self._entries)

    def longest_within(self, want: Sequence[int]) -> StoredPrefix | None:
        """The longest entry that ``want`` begins with, whole (None when none does). Only a whole
        entry is restored: for Gemma 3's sliding-window layers llama.cpp's sequence state keeps the
        cells a continuation of the entry needs, not those of a shorter prefix of it (a prompt
        sharing part of an entry got other scores; tests/test_llm_embedded.py)."""
        w = np.asarray(want, dtype=np.int32)
        best = None
        for entry in self._entries.values():
            n = len(entry.tokens)
            if n <= len(w) and (best is None or n > len(best.tokens)) and np.array_equal(entry.tokens, w[:n]):
                best = entry
        if best is not None:
            self._entries.move_to_end(self._key(best.tokens))
        return best

    def add(self, tokens: Sequence[int], data: Any) -> None:
        """Keep ``data``, the cells of ``tokens`` (a whole number of chunks), evicting the least
        recently used entries beyond the budget."""
        t = np.asarray(tokens, dtype=np.int32)
        if len(t) == 0 or len(t) % self.chunk or len(data) > self.max_bytes:
            return
        key = self._key(t)
        if key in self._entries:
            self._entries.move_to_end(key)
            return
        self._entries[key] = StoredPrefix(t, data)
        self.bytes += len(data)
        while self.bytes > self.max_bytes:
            self._drop(next(iter(self._entries)))

    def _drop(self, key: bytes) -> None:
        self.bytes -= len(self._entries.pop(key).data)

    @staticmethod
    def _key(tokens: np.ndarray) -> bytes:
        return tokens.tobytes()
