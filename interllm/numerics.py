"""The numerical environment behind bit-identical results, pinned before numpy loads.

numpy's bundled OpenBLAS chooses its kernels by CPU (``DYNAMIC_ARCH``) and numpy dispatches its
SIMD loops by CPU too; on an AVX-512 machine both pick other code paths than on an AVX2 one, the
last bits of IK solutions move, and so do the measured costs, the prompts and every metric. So
every process of the project runs with one numerical environment, set here, at ``import
interllm``, before numpy is imported (stages, mission workers, the CLI, the tests and the
benchmarks all import ``interllm`` first; child processes inherit the environment):

- ``OPENBLAS_CORETYPE=Haswell`` on x86-64 CPUs with AVX2 and FMA: OpenBLAS's Haswell kernels run
  on every such CPU (Intel since 2013, AMD Zen; OpenBLAS maps Zen to them as well).
- ``OPENBLAS_NUM_THREADS=1``: the IK problems are 10x10; threads only add scheduling noise.
- ``NPY_DISABLE_CPU_FEATURES``: numpy's dispatch targets above AVX2 (AVX-512), so numpy runs the
  same AVX2 loops on AVX2 and AVX-512 machines.

The caller's values of these variables are overridden (a stranger's shell must not move the
results). ``INTERLLM_NUMERICS=inherit`` keeps the caller's environment instead, for example to
measure another BLAS kernel (``INTERLLM_NUMERICS=inherit OPENBLAS_CORETYPE=SkylakeX``).
Where pinning is impossible (another ISA, an x86-64 CPU without AVX2) nothing is set and
:func:`effective` says so; results then match the committed ones only approximately.

This module imports only the standard library: it must run before numpy.
"""

from __future__ import annotations

import ctypes
import os
import platform
import sys
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path

from interllm.errors import UserError

POLICY_VAR = "INTERLLM_NUMERICS"  # "pinned" (default) | "inherit"
POLICIES = ("pinned", "inherit")
BLAS_KERNEL = "Haswell"  # the OpenBLAS core type every x86-64 CPU with AVX2 + FMA can run
BLAS_THREADS = "1"
# numpy's dispatch targets above AVX2, by numpy release (names changed in numpy 2.4)
_NUMPY_AVX512_TARGETS = {
    (2, 4): "X86_V4 AVX512_ICL AVX512_SPR",
    (0, 0): "AVX512F AVX512CD AVX512_KNL AVX512_KNM AVX512_SKX AVX512_CLX AVX512_CNL AVX512_ICL AVX512_SPR",
}
PINNED_VARS = ("OPENBLAS_CORETYPE", "OPENBLAS_NUM_THREADS", "NPY_DISABLE_CPU_FEATURES")
# CPU flags that decide which kernels the libraries may pick (recorded, not pinned)
SIMD_FLAGS = ("sse4_2", "avx", "avx2", "fma", "f16c", "avx512f", "avx512dq", "avx512bw", "avx512vl",
              "avx512_vnni", "avx512_bf16", "avx512_fp16", "amx_tile", "asimd", "sve")


class NumericsError(UserError, RuntimeError):
    """The numerical environment cannot be pinned as asked (bad ``INTERLLM_NUMERICS``)."""


@dataclass
class Pin:
    """What :func:`pin` did in this process."""

    policy: str  # "pinned" | "inherit"
    applied: dict[str, str] = field(default_factory=dict)  # variables set by the pin
    overridden: dict[str, str] = field(default_factory=dict)  # the caller's values it replaced
    reason: str = ""  # why something was not pinned ("" when everything was)
    numpy_was_loaded: bool = False  # numpy was imported before the pin: it could not take effect


_PIN: Pin | None = None


def cpu_flags() -> set[str]:
    """The CPU's feature flags from /proc/cpuinfo (Linux; empty elsewhere)."""
    try:
        with open("/proc/cpuinfo", encoding="ascii", errors="replace") as f:
            for line in f:
                if line.startswith(("flags", "Features")):
                    return set(line.split(":", 1)[1].split())
    except OSError:
        pass
    return set()


def cpu_model() -> str:
    try:
        with open("/proc/cpuinfo", encoding="ascii", errors="replace") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def _numpy_release() -> tuple[int, int]:
    try:
        major, minor = metadata.version("numpy").split(".")[:2]
        return int(major), int("".join(c for c in minor if c.isdigit()) or 0)
    except (metadata.PackageNotFoundError, ValueError):
        return (0, 0)


def pinned_environment(machine: str | None = None, flags: set[str] | None = None,
                       numpy_release: tuple[int, int] | None = None) -> tuple[dict[str, str], str]:
    """(variables to set, reason for anything left unpinned) for this machine."""
    machine = (machine or platform.machine()).lower()
    flags = cpu_flags() if flags is None else flags
    if machine not in ("x86_64", "amd64"):
        return {}, (f"{machine} is not x86-64: OpenBLAS and numpy choose their own kernels here, "
                    f"so results match the committed (x86-64) ones only approximately")
    env = {"OPENBLAS_NUM_THREADS": BLAS_THREADS}
    release = numpy_release or _numpy_release()
    key = max(k for k in _NUMPY_AVX512_TARGETS if k <= release)
    env["NPY_DISABLE_CPU_FEATURES"] = _NUMPY_AVX512_TARGETS[key]
    if not {"avx2", "fma"} <= flags:
        return env, ("this CPU lacks AVX2/FMA: OpenBLAS's Haswell kernels cannot run, so it keeps the "
                     "kernels it picks; results match the committed ones only approximately")
    env["OPENBLAS_CORETYPE"] = BLAS_KERNEL
    return env, ""


def pin() -> Pin:
    """Set the pinned variables in ``os.environ`` (once per process; idempotent)."""
    global _PIN
    if _PIN is not None:
        return _PIN
    policy = os.environ.get(POLICY_VAR, "pinned").strip().lower() or "pinned"
    if policy not in POLICIES:
        raise NumericsError(f"environment variable {POLICY_VAR}={os.environ[POLICY_VAR]!r} is not valid; "
                            f"choose one of {list(POLICIES)} (unset: pinned)")
    p = Pin(policy=policy, numpy_was_loaded="numpy" in sys.modules)
    if policy == "inherit":
        p.reason = f"{POLICY_VAR}=inherit: the caller's environment chooses the kernels"
    else:
        env, p.reason = pinned_environment()
        for k, v in env.items():
            old = os.environ.get(k)
            if old is not None and old != v:
                p.overridden[k] = old
            os.environ[k] = v
            p.applied[k] = v
    _PIN = p
    return p


# -- what is in effect (after numpy is loaded) -------------------------------------------------
def _loaded_openblas() -> list[Path]:
    """OpenBLAS libraries mapped into this process (numpy's and scipy's bundle one each)."""
    seen: list[Path] = []
    try:
        with open("/proc/self/maps", encoding="ascii", errors="replace") as f:
            for line in f:
                parts = line.split()
                if len(parts) < 6:
                    continue
                p = Path(parts[-1])
                if "openblas" in p.name.lower() and ".so" in p.name and p not in seen:
                    seen.append(p)
    except OSError:
        pass
    return seen


def _blas_info(path: Path) -> dict:
    info: dict = {"library": path.name}
    try:
        lib = ctypes.CDLL(str(path))
    except OSError as e:
        return {**info, "error": str(e)}
    for prefix in ("scipy_openblas", "openblas"):
        for suffix in ("64_", ""):
            core = getattr(lib, f"{prefix}_get_corename{suffix}", None)
            if core is None:
                continue
            core.restype = ctypes.c_char_p
            conf = getattr(lib, f"{prefix}_get_config{suffix}")
            conf.restype = ctypes.c_char_p
            threads = getattr(lib, f"{prefix}_get_num_threads{suffix}")
            threads.restype = ctypes.c_int
            return {**info, "kernel": core().decode(), "threads": int(threads()),
                    "config": conf().decode().strip()}
    return {**info, "error": "no openblas_get_corename symbol"}


def _numpy_simd() -> dict:
    np_mod = sys.modules.get("numpy")
    if np_mod is None:
        return {"loaded": False}
    try:
        from numpy._core import _multiarray_umath as mu  # lazy: numpy loads after the pin; numpy >= 2
    except ImportError:  # numpy 1.x
        from numpy.core import _multiarray_umath as mu  # type: ignore[no-redef]  # lazy: numpy 1.x
    feats = mu.__cpu_features__
    return {"version": np_mod.__version__, "baseline": list(mu.__cpu_baseline__),
            "dispatch_enabled": [t for t in mu.__cpu_dispatch__ if feats.get(t)],
            "dispatch_built": list(mu.__cpu_dispatch__)}


def effective() -> dict:
    """The numerical environment in effect in this process: pin policy, BLAS kernel and threads of
    every loaded OpenBLAS, numpy's SIMD targets, the CPU. Loads numpy if it is not loaded yet."""
    import numpy  # noqa: F401  # lazy: numpy loads after the pin (the libraries to describe)

    p = pin()
    blas = [_blas_info(path) for path in _loaded_openblas()]
    flags = cpu_flags()
    return {
        "policy": p.policy, "pinned": pinned_ok(blas), "reason": p.reason,
        "pinnable": pinned_environment()[1] == "",  # False: another ISA or no AVX2, bit-identity impossible
        "variables": {k: os.environ.get(k) for k in PINNED_VARS},
        "overridden_caller_values": dict(p.overridden),
        "numpy_loaded_before_pin": p.numpy_was_loaded,
        "blas": blas, "numpy_simd": _numpy_simd(),
        "cpu": {"machine": platform.machine(), "model": cpu_model(),
                "simd_flags": sorted(f for f in flags if f in SIMD_FLAGS)},
    }


def pinned_ok(blas: list[dict] | None = None) -> bool:
    """True when the pin is in force: every loaded OpenBLAS runs the pinned kernel with the pinned
    thread count and numpy dispatches nothing above AVX2."""
    p = pin()
    if p.policy != "pinned" or "OPENBLAS_CORETYPE" not in p.applied:
        return False
    blas = [_blas_info(path) for path in _loaded_openblas()] if blas is None else blas
    if any(b.get("kernel") != BLAS_KERNEL or b.get("threads") != int(BLAS_THREADS) for b in blas):
        return False
    simd = _numpy_simd()
    disabled = set(p.applied.get("NPY_DISABLE_CPU_FEATURES", "").split())
    return not (set(simd.get("dispatch_enabled", ())) & disabled)


def summary(eff: dict | None = None) -> str:
    """One line: 'BLAS Haswell x1, numpy SIMD X86_V3 (pinned)'."""
    e = eff or effective()
    kernels = ", ".join(f"{b.get('kernel', '?')} x{b.get('threads', '?')}" for b in e["blas"]) or "none loaded"
    simd = " ".join(e["numpy_simd"].get("dispatch_enabled", ())) or "baseline only"
    state = "pinned" if e["pinned"] else f"NOT pinned: {e['reason'] or 'see provenance'}"
    return f"BLAS {kernels}; numpy SIMD {simd} ({state})"


def for_results(eff: dict) -> dict:
    """The machine-independent part of :func:`effective`: what must be equal for byte-identical
    results (no CPU model, no caller values)."""
    return {"policy": eff["policy"], "pinned": eff["pinned"],
            "blas": sorted({f"{b.get('kernel')} x{b.get('threads')}" for b in eff["blas"]}),
            "numpy_simd": eff["numpy_simd"].get("dispatch_enabled", [])}


def environment_record(prov: dict) -> dict:
    """What metrics/environment.json keeps of a run's provenance: the numerics that results depend
    on, the CPU they were measured on, the llama.cpp build that answered cache misses (see
    :mod:`interllm.llama_build`), Python and the package versions."""
    num = prov.get("numerics") or {}
    build = prov.get("llama_cpp_build")
    llama = ({k: build[k] for k in ("kind", "simd_features", "cmake_args") if k in build}
             if isinstance(build, dict) else {})
    return {"numerics": for_results(num) if "blas" in num else {}, "cpu": num.get("cpu", {}),
            "llama_cpp": llama, "python": prov.get("python"), "packages": prov.get("packages", {})}


def _describe_llama_build(build: dict) -> str:
    if not build:
        return "not recorded"
    return f"{build.get('kind', 'unknown')} ({', '.join(build.get('simd_features', ())) or 'no SIMD features'})"


def describe_environment_change(reference: dict, current: dict) -> list[str]:
    """Lines naming what differs between two :func:`environment_record` dicts (BLAS kernel and
    threads, numpy SIMD targets, CPU features, Python, package versions)."""
    out = []
    rn, cn = reference.get("numerics", {}), current.get("numerics", {})
    for key, label in (("blas", "BLAS kernel x threads"), ("numpy_simd", "numpy SIMD targets"),
                       ("policy", "numerics policy")):
        if rn.get(key) != cn.get(key):
            out.append(f"{label}: reference {rn.get(key)}, here {cn.get(key)}")
    rc, cc = reference.get("cpu", {}), current.get("cpu", {})
    if rc.get("machine") != cc.get("machine"):
        out.append(f"CPU architecture: reference {rc.get('machine')}, here {cc.get('machine')}")
    rf, cf = set(rc.get("simd_flags", ())), set(cc.get("simd_flags", ()))
    if rf != cf:
        out.append(f"CPU SIMD features: here without {sorted(rf - cf) or 'none'}, here also {sorted(cf - rf) or 'none'} "
                   f"(reference CPU: {rc.get('model', '?')}; here: {cc.get('model', '?')})")
    rl, cl = reference.get("llama_cpp") or {}, current.get("llama_cpp") or {}
    if rl != cl:
        out.append(f"llama.cpp build (answers cache misses): reference {_describe_llama_build(rl)}, "
                   f"here {_describe_llama_build(cl)}")
    if reference.get("python") != current.get("python"):
        out.append(f"Python: reference {reference.get('python')}, here {current.get('python')}")
    rp, cp = reference.get("packages", {}), current.get("packages", {})
    for name in sorted(set(rp) | set(cp)):
        if name != "interllm" and rp.get(name) != cp.get(name):
            out.append(f"package {name}: reference {rp.get(name)}, here {cp.get(name)}")
    return out
