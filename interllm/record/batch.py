"""A faster message path for the mcap package's writer (the recorder's hot path)."""

from __future__ import annotations

import struct
from collections.abc import Sequence

from mcap.opcode import Opcode
from mcap.records import MessageIndex
from mcap.writer import Writer

_MESSAGE_HEADER = struct.Struct("<BQHIQQ")  # opcode, record length, channel, sequence, log, publish time


class BatchWriter(Writer):
    """``mcap.writer.Writer`` plus ``add_messages``: many messages in one call, packed with one
    struct call each instead of the per-field writes of ``add_message`` (3-4x less time per
    message, the recorder's hot path). The file is byte-identical to calling ``add_message`` for
    each (tests/test_record_mcap.py checks this); if the mcap package's internals ever change
    shape, it falls back to ``add_message``."""

    def add_messages(self, rows: Sequence[tuple[int, int, bytes, int]]) -> None:
        """rows: (channel_id, log_time = publish_time [ns], data, sequence), in file order."""
        try:
            stats = self._Writer__statistics  # type: ignore[attr-defined]
            cb = self._Writer__chunk_builder  # type: ignore[attr-defined]
            limit = self._Writer__chunk_size  # type: ignore[attr-defined]
            finalize = self._Writer__maybe_finalize_chunk  # type: ignore[attr-defined]
            buf = cb.record_writer._buffer
        except AttributeError:
            cb = None
        if cb is None:
            for ch, t, data, seq in rows:
                self.add_message(channel_id=ch, log_time=t, data=data, publish_time=t, sequence=seq)
            return
        pack, opcode = _MESSAGE_HEADER.pack, int(Opcode.MESSAGE)
        counts, indices = stats.channel_message_counts, cb.message_indices
        for ch, t, data, seq in rows:
            if stats.message_count == 0:
                stats.message_start_time = t
            elif t < stats.message_start_time:
                stats.message_start_time = t
            if t > stats.message_end_time:
                stats.message_end_time = t
            counts[ch] += 1
            stats.message_count += 1
            if cb.num_messages == 0:
                cb.message_start_time = t
            elif t < cb.message_start_time:
                cb.message_start_time = t
            if t > cb.message_end_time:
                cb.message_end_time = t
            idx = indices.get(ch)
            if not idx:
                idx = indices[ch] = MessageIndex(channel_id=ch, records=[])
            offset = buf.tell()
            idx.records.append((t, offset))
            cb.num_messages += 1
            buf.write(pack(opcode, 22 + len(data), ch, seq, t, t))
            buf.write(data)
            if offset + 31 + len(data) > limit:
                finalize()  # compresses and writes the chunk; the builder starts a new buffer
                buf = cb.record_writer._buffer
