"""Checks of typed YAML data against a dataclass schema, before `yaml_load_typed` reads it.

`yaml_load_typed` rejects unknown keys and wrong types, but its messages name no field path;
these checks find the same problems first and name the field (`tables[2].size`), and also
reject NaN and infinities, which it accepts. They raise `FieldError(path, message)`; the
scenario loader turns it into its own ScenarioError.
"""

import dataclasses
import math
import typing


class FieldError(ValueError):
    """A value that does not fit the schema, located by its field path."""

    def __init__(self, path: str, message: str):
        super().__init__(f"{path}: {message}" if path else message)
        self.path = path
        self.message = message


def _type_name(value) -> str:
    return "null" if value is None else type(value).__name__


def check_structure(value, schema, path: str) -> None:
    """Checks raw YAML data against a schema type; raises ScenarioError with the path."""
    origin = typing.get_origin(schema)
    if dataclasses.is_dataclass(schema):
        if not isinstance(value, dict):
            raise FieldError(path, f"expected a mapping of fields, got {value!r}")
        fields = {f.name: f for f in dataclasses.fields(schema)}
        hints = typing.get_type_hints(schema)
        for key, item in value.items():
            child = f"{path}.{key}" if path else str(key)
            if key not in fields:
                known = ", ".join(fields)
                raise FieldError(child, f"unknown field (known fields: {known})")
            check_structure(item, hints[key], child)
    elif origin is list:
        (item_type,) = typing.get_args(schema)
        if not isinstance(value, list):
            raise FieldError(path, f"expected a list, got {value!r}")
        for i, item in enumerate(value):
            check_structure(item, item_type, f"{path}[{i}]")
    elif schema is bool:
        if not isinstance(value, bool):
            raise FieldError(path, f"expected true or false, got {value!r}")
    elif schema is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise FieldError(path, f"expected an integer, got {value!r}")
    elif schema is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise FieldError(path, f"expected a number, got {value!r}")
    elif schema is str:
        if not isinstance(value, str):
            raise FieldError(path, f"expected a string, got {_type_name(value)} {value!r}")
    else:  # pragma: no cover - a schema type this checker does not know
        raise TypeError(f"unsupported schema type {schema} at {path}")


def check_finite(value, path: str) -> None:
    """NaN or inf anywhere is an error, whatever the field."""
    if dataclasses.is_dataclass(value):
        for f in dataclasses.fields(value):
            check_finite(getattr(value, f.name), f"{path}.{f.name}" if path else f.name)
    elif isinstance(value, list):
        for i, item in enumerate(value):
            check_finite(item, f"{path}[{i}]")
    elif isinstance(value, float) and not math.isfinite(value):
        raise FieldError(path, f"must be a finite number, got {value}")
