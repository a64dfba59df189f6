"""Run logging: the Recorder protocol, MCAP writer/reader and rerun replay.

Modules: ``api`` (the Recorder protocol), ``topics`` (the run log's topics, schemas and JSON
encoding), ``foxglove`` (scene, grids and paths as Foxglove messages), ``wire`` (protobuf bytes
of many messages per numpy call: /joint_states, paths), ``sdk_writer`` (the MCAP file through
foxglove-sdk), ``recorder`` (``McapRecorder``), ``reader``, ``rerun_log`` (a run log as rerun
entities), ``replay``, ``figures``.
``McapRecorder`` writes one ``.mcap`` per mission run (Foxglove schemas + JSON planner events),
``read_run`` reads it back (also a killed run's truncated ``.mcap.partial``), ``replay`` /
``replay_main`` turn runs into rerun recordings (rerun is imported only when replaying). Names are imported from their modules on first use
(``interllm.lazy``).
"""

from interllm.lazy import exports_of, lazy_exports

# not lazy: ``replay`` is also the name of its submodule, which importing any record module would
# otherwise leave as the package's attribute
from interllm.record.replay import replay, replay_main  # noqa: E402, F401

_EXPORTS = exports_of({
    "interllm.record.api": ("NullRecorder", "Recorder"),
    "interllm.record.reader": ("RunLog", "RunLogFormatError", "read_run"),
    "interllm.record.recorder": ("McapRecorder",),
    "interllm.record.topics": ("ACTION_SCHEMA",),
})
__all__ = sorted([*_EXPORTS, "replay", "replay_main"])
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
