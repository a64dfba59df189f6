"""The run log's MCAP file, written through Foxglove's SDK (``foxglove-sdk``).

Each writer has a ``foxglove.Context`` of its own, so channels of one run never reach another run's
file. Chunks are compressed on the calling thread (``compression_threads=0``), so the bytes do not
depend on the machine's core count; zstd runs at level 1 (``ZSTD_LEVEL``). The SDK numbers each
channel's messages itself (the MCAP message sequence).
"""

from __future__ import annotations

import os
from collections.abc import Sequence

COMPRESSIONS = ("zstd", "lz4", "none")  # chunk compression
ZSTD_LEVEL = 1  # zstd's fastest level


class FoxgloveSdkWriter:
    """An MCAP file written by foxglove-sdk (module doc). path: the file; compression: one of
    ``COMPRESSIONS``; chunk_size: uncompressed chunk size limit [bytes]."""

    def __init__(self, path: str | os.PathLike, chunk_size: int, compression: str) -> None:
        import foxglove  # lazy: the SDK loads only when a run log is written
        from foxglove.mcap import MCAPCompression, MCAPWriteOptions  # lazy: as above

        codec = {"zstd": MCAPCompression.Zstd, "lz4": MCAPCompression.Lz4, "none": None}[compression]
        self._fx = foxglove
        self._ctx = foxglove.Context()
        self._writer = foxglove.open_mcap(path, allow_overwrite=True, context=self._ctx,
                                          writer_options=MCAPWriteOptions(compression=codec, profile="",
                                                                          chunk_size=chunk_size,
                                                                          compression_level=ZSTD_LEVEL,
                                                                          compression_threads=0))
        self._schemas: list = []
        self._channels: list = []
        self._log: list = []  # per channel: the SDK channel's native log(data: bytes, log_time [ns])

    def register_schema(self, name: str, encoding: str, data: bytes) -> int:
        """A schema; returns its id (MCAP schema ids start at 1)."""
        self._schemas.append(self._fx.Schema(name=name, encoding=encoding, data=data))
        return len(self._schemas)

    def register_channel(self, topic: str, message_encoding: str, schema_id: int) -> int:
        """A channel of ``topic`` with schema ``schema_id``; returns its id for ``add_message(s)``."""
        channel = self._fx.Channel(topic, schema=self._schemas[schema_id - 1], message_encoding=message_encoding,
                                   context=self._ctx)
        self._channels.append(channel)
        self._log.append(channel.base.log)  # serialized bytes go straight to the SDK (no per-call type checks)
        return len(self._channels) - 1

    def add_message(self, channel_id: int, log_time: int, data: bytes) -> None:
        """One serialized message at ``log_time`` = publish time [ns]."""
        self._log[channel_id](data, log_time)

    def add_messages(self, rows: Sequence[tuple[int, int, bytes]]) -> None:
        """rows: (channel_id, log_time = publish_time [ns], data), in file order."""
        log = self._log
        for ch, t, data in rows:
            log[ch](data, t)

    def add_metadata(self, name: str, data: dict[str, str]) -> None:
        self._writer.write_metadata(name, data)

    def add_attachment(self, create_time: int, log_time: int, name: str, media_type: str, data: bytes) -> None:
        self._writer.attach(log_time=log_time, create_time=create_time, name=name, media_type=media_type, data=data)

    def flush(self) -> None:
        self._writer.flush()

    def finish(self) -> None:
        """Close every channel and the file (summary, index, footer)."""
        for ch in self._channels:
            ch.close()
        self._writer.close()
