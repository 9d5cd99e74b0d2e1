"""Build the simulators' configuration dataclasses from plain mappings (TOML files).

Each simulator has one frozen dataclass config whose fields are numbers, strings, booleans,
tuples of numbers, nested config dataclasses, or tuples of them (tables and arrays of tables in
TOML). Unknown keys and wrongly typed values raise :class:`~svrqp.exceptions.ProblemError`
naming the key, so a typo in a config file never silently falls back to a default.
"""

from __future__ import annotations

import dataclasses
import tomllib
import typing
from collections.abc import Mapping
from pathlib import Path
from typing import Any, TypeVar

from svrqp.exceptions import ProblemError

ConfigT = TypeVar("ConfigT")


def from_mapping(cls: type[ConfigT], data: Mapping[str, Any], where: str = "config") -> ConfigT:
    """Instantiate the dataclass ``cls`` from ``data``, converting nested tables recursively.

    Parameters
    ----------
    cls
        A dataclass type (a simulator config or one of its parts).
    data
        Field values by name; fields not given keep their defaults.
    where
        Dotted location used in error messages (e.g. ``"config.ambient"``).

    Returns
    -------
    ConfigT
        The dataclass instance.
    """
    if not isinstance(data, Mapping):
        raise ProblemError(f"{where}: expected a table, got {type(data).__name__}")
    hints = typing.get_type_hints(cls)
    fields = {field.name for field in dataclasses.fields(cls) if field.init}
    unknown = sorted(set(data) - fields)
    if unknown:
        raise ProblemError(f"{where}: unknown key(s) {unknown}; valid keys: {sorted(fields)}")
    values = {name: _convert(hints[name], value, f"{where}.{name}") for name, value in data.items()}
    return cls(**values)


def load_toml(cls: type[ConfigT], path: str | Path) -> ConfigT:
    """Read a TOML file into the config dataclass ``cls`` (see :func:`from_mapping`)."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"config file not found: {path}")
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as err:
        raise ProblemError(f"{path}: invalid TOML: {err}") from err
    return from_mapping(cls, data, where=path.name)


def _convert(hint: Any, value: Any, where: str) -> Any:
    origin = typing.get_origin(hint)
    if dataclasses.is_dataclass(hint):
        return value if isinstance(value, hint) else from_mapping(hint, value, where)
    if origin is tuple:
        (item_hint, _ellipsis) = typing.get_args(hint)
        if isinstance(value, (str, bytes)) or not isinstance(value, (list, tuple)):
            raise ProblemError(f"{where}: expected a list, got {value!r}")
        return tuple(_convert(item_hint, item, f"{where}[{i}]") for i, item in enumerate(value))
    if origin in (dict, Mapping) or hint is dict:
        if not isinstance(value, Mapping):
            raise ProblemError(f"{where}: expected a table, got {value!r}")
        _key_hint, item_hint = typing.get_args(hint)
        return {str(k): _convert(item_hint, v, f"{where}.{k}") for k, v in value.items()}
    if hint is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ProblemError(f"{where}: expected a number, got {value!r}")
        return float(value)
    if hint is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ProblemError(f"{where}: expected an integer, got {value!r}")
        return value
    if hint is bool:
        if not isinstance(value, bool):
            raise ProblemError(f"{where}: expected true or false, got {value!r}")
        return value
    if hint is str:
        if not isinstance(value, str):
            raise ProblemError(f"{where}: expected a string, got {value!r}")
        return value
    raise ProblemError(f"{where}: unsupported config type {hint!r}")
