"""The llama.cpp build behind the embedded model: one pinned, portable CPU baseline.

llama-cpp-python compiles llama.cpp when it is installed, by default with ``GGML_NATIVE``: for the
installing CPU. On an Intel CPU with AVX-512 and AMX such a build crashes on its first decode, and
on any CPU a native build makes cold-run answers depend on that CPU's kernels (AVX-512 and AMX
matrix products round differently from AVX2 ones), the one part of the numerics that
:mod:`interllm.numerics` cannot pin at run time. So ``make install`` builds one baseline:

- x86-64: AVX, AVX2, FMA, F16C, BMI2 (every Intel CPU since Haswell, 2013; every AMD Zen);
  no AVX-VNNI, AVX-512 or AMX.
- aarch64: ARMv8.2-A with dot product and half-precision arithmetic (Neoverse N1 / Graviton 2,
  Ampere Altra, Apple M1 and newer); no SVE, SME or int8 matrix multiply.

``make install LLAMA_NATIVE=1`` builds for the installing CPU instead (faster, not portable); the
choice is written beside the virtual environment (:data:`RECORD_NAME`) and into every run's
provenance, and :func:`check` accepts native-only features only where that record says native.

The wheel is built into a project-local folder named by :func:`build_key` (version, flags, Python,
platform; for native builds also the CPU's flags): pip keys its own wheel cache by version only and
would hand a native wheel built earlier to the pinned install.

Used twice: by the Makefile before anything is installed (``python -m interllm.llama_build ...``:
standard library only, like :mod:`interllm.numerics`), and by the embedded backend at model load
(:func:`check`).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import platform
import sys
import sysconfig
from dataclasses import dataclass
from importlib import metadata
from pathlib import Path

from interllm.errors import UserError
from interllm.numerics import cpu_flags

RECORD_NAME = "llama-build.json"  # in sys.prefix: what `make install` built and installed
REBUILD_PINNED = "make install-llama"  # the command that rebuilds the pinned baseline
REBUILD_NATIVE = "make install-llama LLAMA_NATIVE=1"

# llama.cpp's own names for SIMD features (llama_print_system_info) -> the /proc/cpuinfo flag each
# needs. Features with no CPU flag here (LLAMAFILE, OPENMP, REPACK, ...) are build options.
FEATURE_CPU_FLAG = {
    "SSE3": "pni", "SSSE3": "ssse3", "AVX": "avx", "AVX_VNNI": "avx_vnni", "AVX2": "avx2",
    "F16C": "f16c", "FMA": "fma", "BMI2": "bmi2", "AVX512": "avx512f", "AVX512_VBMI": "avx512vbmi",
    "AVX512_VNNI": "avx512_vnni", "AVX512_BF16": "avx512_bf16", "AMX_INT8": "amx_int8",
    "NEON": "asimd", "ARM_FMA": "asimd", "FP16_VA": "asimdhp", "DOTPROD": "asimddp",
    "MATMUL_INT8": "i8mm", "SVE": "sve", "SME": "sme", "SME2": "sme2",
}


@dataclass(frozen=True)
class Baseline:
    """The pinned build for one CPU architecture."""

    cmake_args: tuple[str, ...]  # CMAKE_ARGS for llama-cpp-python's build
    features: frozenset[str]  # the SIMD features llama_print_system_info lists for it


BASELINES = {
    "x86_64": Baseline(
        cmake_args=("-DGGML_NATIVE=OFF", "-DGGML_BACKEND_DL=OFF", "-DGGML_CPU_ALL_VARIANTS=OFF",
                    "-DGGML_SSE42=ON", "-DGGML_AVX=ON", "-DGGML_AVX2=ON", "-DGGML_FMA=ON",
                    "-DGGML_F16C=ON", "-DGGML_BMI2=ON", "-DGGML_AVX_VNNI=OFF", "-DGGML_AVX512=OFF",
                    "-DGGML_AVX512_VBMI=OFF", "-DGGML_AVX512_VNNI=OFF", "-DGGML_AVX512_BF16=OFF",
                    "-DGGML_AMX_TILE=OFF", "-DGGML_AMX_INT8=OFF", "-DGGML_AMX_BF16=OFF"),
        features=frozenset({"SSE3", "SSSE3", "AVX", "AVX2", "F16C", "FMA", "BMI2"})),
    "aarch64": Baseline(
        cmake_args=("-DGGML_NATIVE=OFF", "-DGGML_BACKEND_DL=OFF", "-DGGML_CPU_ALL_VARIANTS=OFF",
                    "-DGGML_CPU_ARM_ARCH=armv8.2-a+dotprod+fp16"),
        features=frozenset({"NEON", "ARM_FMA", "FP16_VA", "DOTPROD"})),
}
NATIVE_CMAKE_ARGS = ("-DGGML_NATIVE=ON",)
_MACHINE_ALIASES = {"amd64": "x86_64", "x64": "x86_64", "arm64": "aarch64"}


class LlamaBuildError(UserError, RuntimeError):
    """The installed llama.cpp build cannot run here, or is not the pinned baseline."""


def machine() -> str:
    m = platform.machine().lower()
    return _MACHINE_ALIASES.get(m, m)


def baseline(arch: str | None = None) -> Baseline | None:
    """The pinned baseline of ``arch`` (default: this machine), or None for another ISA."""
    return BASELINES.get(arch or machine())


def cmake_args(native: bool, arch: str | None = None) -> tuple[str, ...]:
    """CMAKE_ARGS of the build: the baseline's, or ``-DGGML_NATIVE=ON`` (also on an ISA with no
    pinned baseline, where native is the only build there is)."""
    base = baseline(arch)
    return NATIVE_CMAKE_ARGS if native or base is None else base.cmake_args


def build_kind(native: bool, arch: str | None = None) -> str:
    return "native" if native or baseline(arch) is None else "pinned"


def build_key(version: str, native: bool) -> str:
    """Name of the wheel folder: a function of everything the wheel's code depends on."""
    ident = {"version": version, "cmake_args": cmake_args(native), "python": sys.implementation.cache_tag,
             "platform": sysconfig.get_platform()}
    if build_kind(native) == "native":  # a native wheel is only valid on CPUs with these flags
        ident["cpu_flags"] = sorted(cpu_flags())
    digest = hashlib.sha256(json.dumps(ident, sort_keys=True).encode()).hexdigest()[:12]
    return f"{version}-{build_kind(native)}-{digest}"


def record(version: str, native: bool, wheel: str) -> dict:
    """What ``make install`` writes to ``sys.prefix``/:data:`RECORD_NAME` after installing."""
    return {"version": version, "kind": build_kind(native), "cmake_args": list(cmake_args(native)),
            "key": build_key(version, native), "wheel": str(Path(wheel).resolve()), "machine": machine()}


# -- what is installed, and whether it can run here ----------------------------------------------
def installed_record() -> dict | None:
    """The record ``make install`` left in this environment, or None (installed some other way)."""
    try:
        return json.loads((Path(sys.prefix) / RECORD_NAME).read_text())
    except (OSError, ValueError):
        return None


def installed_wheel_url() -> str | None:
    """Where pip installed llama-cpp-python from (its direct_url.json), None for an index."""
    try:
        text = metadata.distribution("llama_cpp_python").read_text("direct_url.json")
    except metadata.PackageNotFoundError:
        return None
    return json.loads(text).get("url") if text else None


def parse_system_info(text: str) -> dict[str, str]:
    """``llama_print_system_info()`` -> {feature: value} ('CPU : SSE3 = 1 | AVX = 1 | ...')."""
    out = {}
    for part in text.replace(":", "|").split("|"):
        name, sep, value = part.partition("=")
        if sep:
            out[name.strip()] = value.strip()
    return out


def system_info() -> str:
    """llama.cpp's own account of its build (loads the library)."""
    import llama_cpp  # lazy: loads the compiled library; the Makefile path must not need it

    return llama_cpp.llama_print_system_info().decode("utf-8", "replace").strip()


def simd_features(info: dict[str, str]) -> set[str]:
    """The SIMD features a build uses (those with a CPU flag), from :func:`parse_system_info`."""
    return {name for name, value in info.items() if name in FEATURE_CPU_FLAG and value not in ("0", "")}


def describe() -> dict:
    """The build for provenance.json and environment.json: features, kind, flags."""
    try:
        text = system_info()
    except Exception as e:  # noqa: BLE001 - diagnostics must not fail a run
        return {"system_info": f"unavailable ({type(e).__name__}: {e})"}
    rec = installed_record() or {}
    return {"system_info": text, "simd_features": sorted(simd_features(parse_system_info(text))),
            "kind": rec.get("kind", "unknown (not installed by make install)"),
            "cmake_args": rec.get("cmake_args", []), "key": rec.get("key", "")}


def problems(features: set[str], flags: set[str], kind: str | None, arch: str | None = None) -> list[str]:
    """What stops a build with ``features`` from running here as the project expects: features the
    CPU (``flags``) lacks, and native-only features unless the install ``kind`` is native."""
    out = []
    missing = sorted(f for f in features if FEATURE_CPU_FLAG[f] not in flags)
    if missing and flags:  # no /proc/cpuinfo (not Linux): nothing to compare against
        out.append(f"it uses {', '.join(missing)}, which this CPU lacks (it would crash on the first decode)")
    base = baseline(arch)
    if kind != "native" and base is not None:
        extra = sorted(features - base.features)
        if extra:
            out.append(f"it uses {', '.join(extra)}, beyond the pinned baseline "
                       f"({', '.join(sorted(base.features))}): it was built for the installing CPU, "
                       f"so cold-run answers depend on that CPU (and AVX-512/AMX builds crash on some)")
    return out


def check() -> dict:
    """Stop with one message when the installed llama.cpp build cannot run here or is not the
    pinned baseline (unless ``make install LLAMA_NATIVE=1`` chose native); return :func:`describe`."""
    desc = describe()
    if "simd_features" not in desc:
        return desc  # the library did not load: the backend reports that itself
    rec = installed_record()
    flags = cpu_flags()
    found = problems(set(desc["simd_features"]), flags, rec.get("kind") if rec else None)
    if found:
        raise LlamaBuildError(
            f"the installed llama-cpp-python cannot run the embedded model here: {'; '.join(found)}. "
            f"llama.cpp reports: {desc['system_info']}. {_fix(flags, rec)} (in the project folder; about "
            f"5 minutes), or use a server backend (llm=ollama, llm=openai)")
    return desc


def _fix(flags: set[str], rec: dict | None) -> str:
    """The rebuild command for :func:`check`'s message."""
    base = baseline()
    lacking = sorted(f for f in base.features if FEATURE_CPU_FLAG[f] not in flags) if base and flags else []
    if lacking:
        return (f"This CPU lacks the pinned baseline's {', '.join(lacking)}, so only a build for it runs here "
                f"(its cold-run answers match the committed ones only approximately): `{REBUILD_NATIVE}`")
    if rec and rec.get("kind") == "native":
        return f"Rebuild it for this CPU with `{REBUILD_NATIVE}`, or the portable baseline with `{REBUILD_PINNED}`"
    return f"Rebuild it with `{REBUILD_PINNED}`"


# -- the Makefile's entry point ----------------------------------------------------------------
def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m interllm.llama_build", description=__doc__.split("\n")[0])
    ap.add_argument("what", choices=["key", "cmake-args", "kind", "record"])
    ap.add_argument("--version", required=True, help="llama-cpp-python version (requirements.lock)")
    ap.add_argument("--native", default="0", help="1: build for this CPU (LLAMA_NATIVE=1)")
    ap.add_argument("--wheel", default="", help="with 'record': the installed wheel file")
    args = ap.parse_args(argv)
    native = args.native.strip() not in ("", "0", "false", "no", "off")
    if args.what == "key":
        print(build_key(args.version, native))
    elif args.what == "cmake-args":
        print(" ".join(cmake_args(native)))
    elif args.what == "kind":
        print(build_kind(native))
    else:
        print(json.dumps(record(args.version, native, args.wheel), indent=2, sort_keys=True))
    return 0


if __name__ == "__main__":
    sys.exit(main())
