"""The store of earlier prompts' KV cells (interllm/llm/prefix_store.py), without a model: which entry
a prompt reuses (only one it begins with whole) and what the byte budget evicts. The bit-identity of
restored cells with evaluated ones is tested on the real model in tests/test_llm_embedded.py."""

from __future__ import annotations

from interllm.llm.prefix_store import PrefixStore

C = 4  # chunk [tokens]


def test_the_longest_entry_the_prompt_begins_with_whole_is_the_one():
    store = PrefixStore(max_bytes=1000, chunk=C)
    store.add(list(range(4)), b"a" * 4)
    store.add(list(range(8)), b"b" * 8)
    store.add([0, 1, 2, 3, 9, 9, 9, 9, 9, 9, 9, 9], b"c" * 12)
    assert store.longest_within(list(range(10))).data == b"b" * 8
    assert store.longest_within([0, 1, 2, 3, 4, 5, 6, 99]).data == b"a" * 4  # shares 7 of the second: not whole
    assert store.longest_within([0, 1, 2, 3, 9, 9, 9, 9, 9, 9, 9, 9, 1]).data == b"c" * 12
    assert store.longest_within(list(range(6))).data == b"a" * 4
    assert store.longest_within([5, 5, 5, 5]) is None and store.longest_within([0, 1]) is None


def test_only_whole_chunks_are_kept_once():
    store = PrefixStore(max_bytes=1000, chunk=C)
    store.add(list(range(6)), b"x")  # not a whole number of chunks
    assert len(store) == 0
    store.add(list(range(8)), b"y" * 8)
    store.add(list(range(8)), b"y" * 8)
    assert len(store) == 1 and store.bytes == 8


def test_the_least_recently_used_entries_go_beyond_the_budget():
    store = PrefixStore(max_bytes=25, chunk=C)
    a, b, c = [1] * 4, [2] * 4, [3] * 4
    store.add(a, b"." * 10)
    store.add(b, b"." * 10)
    store.longest_within(a + [0])  # a is used: b is now the least recent
    store.add(c, b"." * 10)
    assert store.bytes == 20 and store.longest_within(b) is None
    assert store.longest_within(a) is not None and store.longest_within(c) is not None
    store.add([4] * 4, b"." * 26)  # larger than the whole budget: not kept, nothing evicted for it
    assert store.bytes == 20
