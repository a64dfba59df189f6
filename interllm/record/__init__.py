"""Run logging: the Recorder protocol, MCAP writer/reader and rerun replay.

``McapRecorder`` writes one ``.mcap`` per mission run (Foxglove schemas + JSON planner events),
``read_run`` reads it back (also a killed run's truncated ``.mcap.partial``), ``replay`` /
``replay_main`` turn runs into rerun recordings (rerun is imported only when replaying).
"""

from interllm.record.api import NullRecorder, Recorder
from interllm.record.mcap_writer import ACTION_SCHEMA, McapRecorder
from interllm.record.reader import RunLog, RunLogFormatError, read_run
from interllm.record.replay import replay, replay_main

__all__ = ["ACTION_SCHEMA", "McapRecorder", "NullRecorder", "Recorder", "RunLog", "RunLogFormatError", "read_run",
           "replay", "replay_main"]
