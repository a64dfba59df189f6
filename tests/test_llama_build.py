"""The llama.cpp build is the pinned, portable baseline (interllm/llama_build.py): checked on what
was built and installed, not only on whether it runs here, so a native build fails these tests on
any machine, also one whose CPU has nothing beyond the baseline."""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest

from interllm import llama_build
from interllm.llama_build import BASELINES, LlamaBuildError, parse_system_info, problems

ROOT = Path(__file__).resolve().parents[1]
AVX512_INFO = ("CPU : SSE3 = 1 | SSSE3 = 1 | AVX = 1 | AVX2 = 1 | F16C = 1 | FMA = 1 | BMI2 = 1 | AVX512 = 1 | "
               "AVX512_VBMI = 1 | AVX512_VNNI = 1 | AVX512_BF16 = 1 | AMX_INT8 = 1 | LLAMAFILE = 1 | OPENMP = 1 | "
               "REPACK = 1 | ")
X86 = BASELINES["x86_64"]
ZEN3_FLAGS = {"pni", "ssse3", "sse4_2", "avx", "avx2", "fma", "f16c", "bmi2"}
SPR_FLAGS = ZEN3_FLAGS | {"avx512f", "avx512vbmi", "avx512_vnni", "avx512_bf16", "amx_int8", "amx_tile"}


def test_system_info_parses():
    info = parse_system_info(AVX512_INFO)
    assert info["AVX512"] == "1" and info["OPENMP"] == "1"
    assert llama_build.simd_features(info) == X86.features | {"AVX512", "AVX512_VBMI", "AVX512_VNNI",
                                                              "AVX512_BF16", "AMX_INT8"}


def test_native_avx512_build_is_refused_on_the_default_path():
    feats = llama_build.simd_features(parse_system_info(AVX512_INFO))
    found = problems(feats, SPR_FLAGS, kind="pinned", arch="x86_64")
    assert len(found) == 1 and "AMX_INT8, AVX512, AVX512_BF16" in found[0] and "beyond the pinned baseline" in found[0]
    assert problems(feats, SPR_FLAGS, kind=None, arch="x86_64") == found  # installed by hand: same rule
    assert problems(feats, SPR_FLAGS, kind="native", arch="x86_64") == []  # LLAMA_NATIVE=1 was chosen


def test_build_the_cpu_cannot_run_is_refused_even_when_native():
    feats = llama_build.simd_features(parse_system_info(AVX512_INFO))
    found = problems(feats, ZEN3_FLAGS, kind="native", arch="x86_64")
    assert found and "which this CPU lacks" in found[0] and "AVX512" in found[0]
    assert problems(set(X86.features), ZEN3_FLAGS, kind="pinned", arch="x86_64") == []


def test_check_stops_with_the_rebuild_command(monkeypatch):
    monkeypatch.setattr(llama_build, "system_info", lambda: AVX512_INFO)
    monkeypatch.setattr(llama_build, "cpu_flags", lambda: SPR_FLAGS)
    monkeypatch.setattr(llama_build, "machine", lambda: "x86_64")
    monkeypatch.setattr(llama_build, "installed_record", lambda: {"kind": "pinned"})
    with pytest.raises(LlamaBuildError, match=r"AVX512.*`make install-llama`"):
        llama_build.check()


def test_cpu_without_the_baseline_is_told_to_build_natively(monkeypatch):
    monkeypatch.setattr(llama_build, "system_info", lambda: "CPU : SSE3 = 1 | SSSE3 = 1 | AVX = 1 | AVX2 = 1 | "
                        "F16C = 1 | FMA = 1 | BMI2 = 1 | OPENMP = 1 |")
    monkeypatch.setattr(llama_build, "cpu_flags", lambda: {"pni", "ssse3", "sse4_2", "avx"})  # Sandy Bridge
    monkeypatch.setattr(llama_build, "machine", lambda: "x86_64")
    monkeypatch.setattr(llama_build, "installed_record", lambda: {"kind": "pinned"})
    with pytest.raises(LlamaBuildError, match=r"lacks the pinned baseline's AVX2, BMI2, F16C, FMA.*LLAMA_NATIVE=1"):
        llama_build.check()


def test_wheel_key_names_version_flags_and_kind():
    pinned, native = llama_build.build_key("0.3.36", False), llama_build.build_key("0.3.36", True)
    if llama_build.baseline() is not None:
        assert pinned.startswith("0.3.36-pinned-") and native.startswith("0.3.36-native-") and pinned != native
    assert llama_build.build_key("0.3.37", False) != pinned
    assert "-DGGML_NATIVE=OFF" in X86.cmake_args and "-DGGML_AVX512=OFF" in X86.cmake_args
    assert "-DGGML_AMX_INT8=OFF" in X86.cmake_args and "-DGGML_AVX2=ON" in X86.cmake_args


# -- what `make install` built and installed in this environment --------------------------------
@pytest.fixture(scope="module")
def record() -> dict:
    rec = llama_build.installed_record()
    if rec is None:
        pytest.fail(f"no {llama_build.RECORD_NAME} in this environment: llama-cpp-python was not installed "
                    f"by `make install` (run `{llama_build.REBUILD_PINNED}`)")
    return rec


def test_installed_build_is_the_pinned_baseline(record):
    base = llama_build.baseline()
    if base is None:
        pytest.skip(f"no pinned baseline for {llama_build.machine()}: the native build is the only one")
    assert record["kind"] == "pinned", f"installed with LLAMA_NATIVE=1; the tests expect `{llama_build.REBUILD_PINNED}`"
    assert tuple(record["cmake_args"]) == base.cmake_args
    assert record["key"] == llama_build.build_key(record["version"], native=False)
    # llama.cpp's own account of its build: exactly the baseline's SIMD features
    assert llama_build.simd_features(parse_system_info(llama_build.system_info())) == base.features


def test_installed_package_is_the_recorded_wheel(record):
    from importlib import metadata

    url = llama_build.installed_wheel_url()
    assert url == Path(record["wheel"]).as_uri(), (
        f"llama-cpp-python was installed from {url or 'a package index (built by pip for this CPU)'}, not "
        f"from the pinned wheel {record['wheel']}; run `{llama_build.REBUILD_PINNED}`")
    assert metadata.version("llama_cpp_python") == record["version"]
    assert Path(record["wheel"]).is_file()


def test_second_make_install_is_a_no_op(record):
    out = subprocess.run(["make", "-q", "install"], cwd=ROOT, capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, f"`make install` would run again:\n{out.stdout}{out.stderr}"


def test_provenance_records_the_build():
    desc = llama_build.describe()
    assert set(desc) >= {"system_info", "simd_features", "kind", "cmake_args"}
    from interllm.numerics import describe_environment_change, environment_record

    prov = {"llama_cpp_build": desc}
    native = {**desc, "kind": "native", "simd_features": sorted(X86.features | {"AVX512"})}
    lines = describe_environment_change(environment_record(prov), environment_record({"llama_cpp_build": native}))
    assert len(lines) == 1 and "llama.cpp build" in lines[0] and "here native" in lines[0] and "AVX512" in lines[0]
    json.dumps(desc)  # JSON-serialisable as provenance.json needs
