"""JSON-schema checks of requests and answers (validators compiled once per schema)."""

from __future__ import annotations

import json
from typing import Any, Optional

import jsonschema


def validate_schema(schema: dict) -> None:
    """Raise ValueError unless ``schema`` is a valid JSON Schema (checked once per schema)."""
    _validator(schema)




_VALIDATORS: dict[str, Any] = {}


def _validator(schema: dict):
    k = json.dumps(schema, sort_keys=True)
    v = _VALIDATORS.get(k)
    if v is None:
        if len(_VALIDATORS) > 512:
            _VALIDATORS.clear()
        try:
            jsonschema.Draft202012Validator.check_schema(schema)
        except jsonschema.SchemaError as e:
            raise ValueError(f"LLMRequest.schema is not a valid JSON Schema: {e.message}") from None
        v = _VALIDATORS[k] = jsonschema.Draft202012Validator(schema)
    return v


def check_answer(text: str, schema: Optional[dict]) -> tuple[Any, Optional[str]]:
    """(parsed, None) when ``text`` is JSON satisfying ``schema``; (None, error text) otherwise."""
    if schema is None:
        return None, None
    try:
        parsed = json.loads(text)
    except json.JSONDecodeError as e:
        return None, f"the answer is not valid JSON ({e.msg} at line {e.lineno} column {e.colno})"
    errs = sorted(_validator(schema).iter_errors(parsed), key=lambda e: list(e.path))
    if errs:
        e = errs[0]
        where = "/".join(str(p) for p in e.path) or "(root)"
        return None, f"the answer violates the JSON schema at {where}: {e.message}"
    return parsed, None
