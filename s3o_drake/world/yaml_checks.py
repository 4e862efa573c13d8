"""Reading YAML text strictly, and checking typed YAML data against a dataclass schema
before `yaml_load_typed` reads it.

`yaml_load_typed` rejects unknown keys and wrong types, but its messages name no field path;
these checks find the same problems first and name the field (`tables[2].size`), and also
reject what it accepts: NaN, infinities, numbers too large to be meant, duplicate keys.
They raise `FieldError(path, message)`, always one line; the scenario loader turns it into
its own ScenarioError.
"""

import dataclasses
import math
import re
import reprlib
import types
import typing

import yaml

MAX_MAGNITUDE = 1e6
"""No number in a file means more than this in size (metres, seconds, radians, rewards):
larger ones are typos or overflows, and they overflow what is computed from them."""
INT64_MAX = 2**63 - 1
MAX_DEPTH = 32
"""Schemas nest a few levels; deeper YAML is rejected before Python's recursion limit is."""
# YAML 1.2's floats that PyYAML (YAML 1.1) reads as strings: an exponent without a dot or
# without a sign (1e-3, 2E5). yaml_load_typed accepts them; so must the checks.
_FLOAT_12 = re.compile(r"^[-+]?(?:[0-9][0-9_]*)(?:\.[0-9_]*)?[eE][-+]?[0-9]+$")

# Values quoted in messages are cut short: a message is one line, whatever the file holds.
_short = reprlib.Repr()
_short.maxstring = 40
_short.maxother = 40
_short.maxlist = _short.maxdict = 6
_short.maxlevel = 3


class FieldError(ValueError):
    """A value that does not fit the schema, located by its field path."""

    def __init__(self, path: str, message: str):
        super().__init__(f"{path}: {message}" if path else message)
        self.path = path
        self.message = message

    def __reduce__(self):
        # Raised in a worker process, it crosses back whole (the default pickles only
        # the message, which __init__ cannot take alone).
        return type(self), (self.path, self.message)


def quoted(value: object) -> str:
    """`value` as a message quotes it: its repr, cut short, on one line."""
    return _short.repr(value)


def field_path(parent: str, key: object) -> str:
    """The path of `key` in the mapping at `parent`: `parent.key`, or `parent['odd key']`
    for a key that is not a plain name (so that the path stays one unambiguous line)."""
    if isinstance(key, str) and key.isidentifier() and key.isascii():
        return f"{parent}.{key}" if parent else key
    return f"{parent}[{quoted(key)}]"


class _StrictComposer(yaml.composer.Composer):
    """PyYAML's composer with duplicate keys and deep nesting rejected (as FieldError
    naming where). It composes the nodes from the events of whichever parser it is
    mixed with (`_StrictLoader`, `_FastStrictLoader`)."""

    def __init__(self) -> None:
        super().__init__()
        self._parts: list[object] = []

    def _path(self, end: int | None = None) -> str:
        """The field path of the node being composed (of its first `end` parts)."""
        path = ""
        for part in self._parts[:end]:
            if isinstance(part, int):
                path += f"[{part}]"
            elif part is not None:
                path = field_path(path, part)
        return path

    def compose_node(self, parent, index):
        # `index` is the key node of a mapping's value, the position in a sequence, or
        # None for the root and for keys.
        if len(self._parts) >= MAX_DEPTH:
            # Named by the innermost key and the first position in it (a path of 32 [0]s
            # would name nothing more).
            keys = [i for i, part in enumerate(self._parts) if isinstance(part, str)]
            path = self._path((keys[-1] if keys else 0) + 2)
            raise FieldError(path, f"nested more than {MAX_DEPTH} levels deep")
        part = index.value if isinstance(index, yaml.ScalarNode) else index
        self._parts.append(part)
        try:
            return super().compose_node(parent, index)
        finally:
            self._parts.pop()

    def compose_mapping_node(self, anchor):
        node = super().compose_mapping_node(anchor)
        seen: dict[tuple[str, str], int] = {}
        for key, _ in node.value:
            if not isinstance(key, yaml.ScalarNode):
                continue
            if (key.tag, key.value) in seen:
                self._parts.append(key.value)
                path = self._path()
                self._parts.pop()
                raise FieldError(path, f"duplicate key (also on line {seen[key.tag, key.value]})")
            seen[key.tag, key.value] = key.start_mark.line + 1
        return node


class _StrictLoader(yaml.reader.Reader, yaml.scanner.Scanner, yaml.parser.Parser,
                    _StrictComposer, yaml.constructor.SafeConstructor, yaml.resolver.Resolver):
    """PyYAML's safe loader, strict (`_StrictComposer`), with YAML 1.2's exponent floats
    read as floats. All in Python: its errors are the ones `load_yaml` reports."""

    def __init__(self, stream) -> None:
        yaml.reader.Reader.__init__(self, stream)
        yaml.scanner.Scanner.__init__(self)
        yaml.parser.Parser.__init__(self)
        _StrictComposer.__init__(self)
        yaml.constructor.SafeConstructor.__init__(self)
        yaml.resolver.Resolver.__init__(self)


_StrictLoader.add_implicit_resolver("tag:yaml.org,2002:float", _FLOAT_12, list("-+0123456789"))

if yaml.__with_libyaml__:
    class _FastStrictLoader(_StrictComposer, yaml.cyaml.CParser, yaml.constructor.SafeConstructor,
                            yaml.resolver.Resolver):
        """`_StrictLoader` with libyaml's parser: the scanning, most of a file's time (a
        generated task reads 4x faster). Composing stays in Python, where the checks are."""

        def __init__(self, stream) -> None:
            yaml.cyaml.CParser.__init__(self, stream)
            _StrictComposer.__init__(self)
            yaml.constructor.SafeConstructor.__init__(self)
            yaml.resolver.Resolver.__init__(self)

    _FastStrictLoader.add_implicit_resolver("tag:yaml.org,2002:float", _FLOAT_12,
                                            list("-+0123456789"))
else:
    _FastStrictLoader = _StrictLoader


def load_yaml(text: str) -> object:
    """Parses YAML text as `yaml.safe_load` does, but strictly (see _StrictComposer); a
    syntax error is a FieldError at `line N`."""
    try:
        return yaml.load(text, Loader=_FastStrictLoader)
    except FieldError:
        raise
    except yaml.YAMLError:
        pass
    # libyaml names a problem less exactly (no offending character, byte offsets): the
    # Python parser says what and where.
    try:
        return yaml.load(text, Loader=_StrictLoader)
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        if mark is not None:
            where = f"line {mark.line + 1}"
        elif isinstance(e, yaml.reader.ReaderError):  # a character YAML does not allow
            where = f"line {text.count(chr(10), 0, e.position) + 1}"
        else:
            where = "YAML"
        problem = getattr(e, "problem", None) or str(e)
        if isinstance(e, yaml.reader.ReaderError):
            problem = f"unacceptable character #x{e.character:04x}"
        raise FieldError(where, f"not valid YAML: {problem.splitlines()[0]}") from None


def _type_name(value) -> str:
    return "null" if value is None else type(value).__name__


def check_structure(value, schema, path: str) -> None:
    """Checks raw YAML data against a schema type; raises FieldError with the path."""
    origin = typing.get_origin(schema)
    if dataclasses.is_dataclass(schema):
        if not isinstance(value, dict):
            raise FieldError(path, f"expected a mapping of fields, got {quoted(value)}")
        fields = {f.name: f for f in dataclasses.fields(schema)}
        hints = typing.get_type_hints(schema)
        for key, item in value.items():
            child = field_path(path, key)
            if key not in fields:
                known = ", ".join(fields)
                raise FieldError(child, f"unknown field {quoted(key)} (known fields: {known})")
            check_structure(item, hints[key], child)
    elif hasattr(schema, "__fields__"):  # one of Drake's config structs
        if not isinstance(value, dict):
            raise FieldError(path, f"expected a mapping of fields, got {quoted(value)}")
        fields = {f.name: f.type for f in schema.__fields__}
        for key, item in value.items():
            child = field_path(path, key)
            if key not in fields:
                known = ", ".join(fields)
                raise FieldError(child, f"unknown field {quoted(key)} (known fields: {known})")
            if fields[key] in (bool, int, float, str):
                check_structure(item, fields[key], child)
    elif origin in (typing.Union, types.UnionType) and type(None) in typing.get_args(schema):
        if value is not None:
            (inner,) = [t for t in typing.get_args(schema) if t is not type(None)]
            check_structure(value, inner, path)
    elif origin is list:
        (item_type,) = typing.get_args(schema)
        if not isinstance(value, list):
            raise FieldError(path, f"expected a list, got {quoted(value)}")
        for i, item in enumerate(value):
            check_structure(item, item_type, f"{path}[{i}]")
    elif schema is bool:
        if not isinstance(value, bool):
            raise FieldError(path, f"expected true or false, got {quoted(value)}")
    elif schema is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise FieldError(path, f"expected an integer, got {quoted(value)}")
        if abs(value) > INT64_MAX:
            raise FieldError(path, f"expected a 64-bit integer, got {quoted(value)}")
    elif schema is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise FieldError(path, f"expected a number, got {quoted(value)}")
        _check_number(value, path)
    elif schema is str:
        if not isinstance(value, str):
            raise FieldError(path, f"expected a string, got {_type_name(value)} "
                                   f"{quoted(value)}")
    else:  # pragma: no cover - a schema type this checker does not know
        raise TypeError(f"unsupported schema type {schema} at {path}")


def _check_number(value: float, path: str) -> None:
    if isinstance(value, float) and not math.isfinite(value):
        raise FieldError(path, f"must be a finite number, got {value}")
    if abs(value) > MAX_MAGNITUDE:  # an int this large would not even convert to float
        raise FieldError(path, f"must be at most {MAX_MAGNITUDE:g} in size, got "
                               f"{quoted(value) if isinstance(value, int) else f'{value:g}'}")
