"""Inter-LLM: interleaved LLM and motion planning for multi-object collection."""

__version__ = "0.1.0"
