"""Inter-LLM: interleaved LLM and motion planning for multi-object collection.

Importing the package pins the numerical environment (BLAS kernel and threads, numpy's SIMD
targets) for this process and its children before numpy loads: see :mod:`interllm.numerics`.
"""

from interllm.numerics import pin as _pin_numerics

_pin_numerics()

__version__ = "0.1.0"
