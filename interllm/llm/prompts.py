"""Prompt templates: text files ``interllm/llm/prompts/<name>.txt`` shipped as package data.

``load_template(name)`` returns a :class:`Template` with the text and its sha256 (the hash goes
into the LLM cache key, so editing a template invalidates exactly the calls that used it).
``Template.render(**fields)`` fills ``str.format``-style fields; literal braces in a template
(e.g. JSON examples) must be doubled: ``{{`` and ``}}``.
"""

from __future__ import annotations

import functools
import hashlib
import string
from dataclasses import dataclass
from pathlib import Path
from typing import Optional

PROMPT_DIR = Path(__file__).with_name("prompts")


class TemplateError(KeyError):
    """A template is missing, or rendering it lacks a field."""

    def __str__(self) -> str:  # KeyError would repr() the message
        return str(self.args[0]) if self.args else ""


@dataclass(frozen=True)
class Template:
    name: str
    text: str
    sha256: str

    @property
    def fields(self) -> tuple[str, ...]:
        """Names of the replacement fields, in order of first use."""
        out: list[str] = []
        for _, field, _, _ in string.Formatter().parse(self.text):
            if field is not None and field != "":
                base = field.split(".")[0].split("[")[0]
                if base not in out:
                    out.append(base)
        return tuple(out)

    def render(self, **kw) -> str:
        """Fill the template's ``{field}`` slots; a missing field raises naming it and the valid ones."""
        missing = [f for f in self.fields if f not in kw]
        if missing:
            raise TemplateError(f"template {self.name!r} needs field(s) {missing}; "
                                f"its fields are {list(self.fields)}")
        try:
            return self.text.format(**kw)
        except (IndexError, ValueError) as e:
            raise TemplateError(f"template {self.name!r} cannot be rendered ({e}); positional "
                                f"'{{}}' fields are not allowed and literal braces must be doubled") from None


def template_names(prompt_dir: Optional[Path] = None) -> list[str]:
    d = Path(prompt_dir) if prompt_dir is not None else PROMPT_DIR
    return sorted(p.stem for p in d.glob("*.txt")) if d.is_dir() else []


@functools.lru_cache(maxsize=256)
def _load(path: str, mtime_ns: int, name: str) -> Template:
    data = Path(path).read_bytes()
    return Template(name=name, text=data.decode("utf-8"), sha256=hashlib.sha256(data).hexdigest())


def load_template(name: str, prompt_dir: Optional[str | Path] = None) -> Template:
    """Load template ``name`` (without ``.txt``) from ``prompt_dir`` (default: package prompts/)."""
    d = Path(prompt_dir) if prompt_dir is not None else PROMPT_DIR
    path = d / f"{name}.txt"
    if "/" in name or "\\" in name or not path.is_file():
        raise TemplateError(f"prompt template {name!r} not found in {d}; valid templates: "
                            f"{template_names(d)}")
    return _load(str(path), path.stat().st_mtime_ns, name)


def template_hash(name: str, prompt_dir: Optional[str | Path] = None) -> str:
    """sha256 of template ``name``'s file bytes ("" for the empty name: no template)."""
    return load_template(name, prompt_dir).sha256 if name else ""
