"""Config values checked against their dataclass field's annotation, and the error a bad config
value raises (the message names the key, where it came from and what it must be)."""

from __future__ import annotations

from interllm.errors import UserError


class ConfigError(UserError, ValueError):
    """A configuration value is invalid; the message names the key and the valid values."""


def type_name(tp: str) -> str:
    return {"int": "an integer", "float": "a number", "str": "a string", "bool": "true or false",
            "list[str]": "a list of strings", "list[float]": "a list of numbers"}.get(tp, tp)


def coerce(value, tp: str, key: str, source: str):
    """``value`` checked against the field annotation ``tp`` (as written in the dataclass)."""
    where = f" (in {source})" if source else ""
    optional = tp.startswith("Optional[")
    base = tp[len("Optional["):-1] if optional else tp
    if value is None:
        if optional:
            return None
        raise ConfigError(f"config key '{key}'{where} must be {type_name(base)}, got null")
    is_bool = isinstance(value, bool)
    if base == "bool" and is_bool:
        return value
    if base == "int" and isinstance(value, int) and not is_bool:
        return value
    if base == "float" and isinstance(value, (int, float)) and not is_bool:
        return float(value)
    if base == "str" and isinstance(value, str):
        return value
    if base == "list[str]" and isinstance(value, list) and all(isinstance(x, str) for x in value):
        return list(value)
    if base == "list[float]" and isinstance(value, list) and all(
            isinstance(x, (int, float)) and not isinstance(x, bool) for x in value):
        return [float(x) for x in value]
    hint = ""
    if base == "list[str]" and isinstance(value, str):
        hint = f"; write a list, e.g. -S '{key}=[{value}]'"
    elif base == "int" and isinstance(value, float) and not is_bool:
        hint = f"; {value} is not a whole number"
    raise ConfigError(f"config key '{key}'{where} must be {type_name(base)}"
                      f"{' or null' if optional else ''}, got {value!r} ({type(value).__name__}){hint}")


def check(cond: bool, key: str, msg: str) -> None:
    """Raise ConfigError naming ``key`` with ``msg`` unless ``cond``."""
    if not cond:
        raise ConfigError(f"config key '{key}': {msg}")


def choice(value: str, key: str, valid: tuple[str, ...]) -> None:
    """Raise ConfigError naming ``key`` and the valid choices unless ``value`` is one of ``valid``."""
    check(value in valid, key, f"{value!r} is not valid; choose one of {list(valid)}")
