"""Run logging: the Recorder protocol, MCAP writer/reader and rerun replay.

Modules: ``api`` (the Recorder protocol), ``topics`` (the run log's topics, schemas and JSON
encoding), ``foxglove`` (scene, grids and paths as Foxglove messages), ``wire`` (protobuf bytes
of many messages per numpy call: /joint_states, paths), ``sdk_writer`` (the MCAP file through
foxglove-sdk), ``recorder`` (``McapRecorder``), ``reader``, ``rerun_log`` (a run log as rerun
entities), ``replay``, ``figures``.
``McapRecorder`` writes one ``.mcap`` per mission run (Foxglove schemas + JSON planner events),
``read_run`` reads it back (also a killed run's truncated ``.mcap.partial``), ``replay`` /
``replay_main`` turn runs into rerun recordings (rerun is imported only when replaying).
"""

from interllm.record.api import NullRecorder, Recorder
from interllm.record.reader import RunLog, RunLogFormatError, read_run
from interllm.record.recorder import McapRecorder
from interllm.record.replay import replay, replay_main
from interllm.record.topics import ACTION_SCHEMA

__all__ = ["ACTION_SCHEMA", "McapRecorder", "NullRecorder", "Recorder", "RunLog", "RunLogFormatError", "read_run",
           "replay", "replay_main"]
