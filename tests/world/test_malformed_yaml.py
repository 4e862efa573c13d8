"""Random malformed scenario files, made by mutating the shipped ones (issue 19, item 1).

Users write scenario files by hand. Whatever a file holds (a wrong type, a key missing or
unknown or given twice, NaN, a huge number, a name in another script, deep nesting, bytes
that are not text), the loader raises one ScenarioError that names the field, and `run`
answers with one line on stderr naming the file and the field, exit status 2, before any
planning, and writes nothing. A mutation that leaves the file valid (a key removed: its
default) must pass validation and reach the simulation's set-up.
"""

import contextlib
import copy
import dataclasses
import io
import os
import re
import subprocess
import sys
import tempfile
import typing
from pathlib import Path
from unittest import mock

import pytest
import yaml
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from s3o_drake.commands.run_scenario import main as run_main
from s3o_drake.world.scenario import Scenario, load_scenario
from s3o_drake.world.scenario_checks import ScenarioError

REPO = Path(__file__).resolve().parents[2]
BASES = [REPO / "scenarios" / "restaurant.yaml",
         *sorted((REPO / "scenarios" / "small").glob("*.yaml")),
         REPO / "scenarios" / "generated" / "task_000.yaml"]
DOCUMENTS = {path.name: yaml.safe_load(path.read_text()) for path in BASES}
# Bounded: the suite stays fast. S3O_PROPERTY_EXAMPLES=1000 tries many more.
EXAMPLES = settings(max_examples=int(os.environ.get("S3O_PROPERTY_EXAMPLES", "40")),
                    deadline=None, database=None,
                    suppress_health_check=[HealthCheck.too_slow])
# A field path as the validator writes it: tables[0].size[2], planner.top_k, [''] ...
_KEY = r"""\[(?:'(?:[^'\\]|\\.)*'|"(?:[^"\\]|\\.)*"|[^\]'"]*)\]"""  # [0], ['a b'], [None]
FIELD = re.compile(rf"^(\w+|{_KEY})({_KEY}|\.\w+)*$")
PLACEHOLDER = "zz_mutation_placeholder"


class ValidationPassedError(Exception):
    """Validation passed: `run` went on to set up the simulation (Meshcat first)."""


# --- documents and paths ---------------------------------------------------------------------

Path_ = tuple  # a node's address in a document: its keys and indices


def nodes(data, path: Path_ = ()) -> list[Path_]:
    """Every node of a document, the root first."""
    found = [path]
    if isinstance(data, dict):
        for key, value in data.items():
            found += nodes(value, (*path, key))
    elif isinstance(data, list):
        for i, value in enumerate(data):
            found += nodes(value, (*path, i))
    return found


def get(data, path: Path_):
    for part in path:
        data = data[part]
    return data


def replaced(data, path: Path_, value):
    """A copy of `data` with the node at `path` replaced."""
    if not path:
        return value
    data = copy.deepcopy(data)
    get(data, path[:-1])[path[-1]] = value
    return data


def dotted(path: Path_) -> str:
    """The field path the validator names (`tables[0].size[1]`)."""
    text = ""
    for part in path:
        text += f"[{part}]" if isinstance(part, int) else (f".{part}" if text else part)
    return text


def within(found: str, expected: str) -> bool:
    """Whether the field path `found` is `expected` or inside it."""
    return expected == "" or found == expected or found.startswith((expected + ".",
                                                                    expected + "["))


def dump(data) -> bytes:
    return yaml.safe_dump(data, sort_keys=False, allow_unicode=True).encode()


@st.composite
def document(draw, where=lambda data, path: True):
    """(base name, its data, the path of a node of it that `where` accepts)."""
    name = draw(st.sampled_from(sorted(DOCUMENTS)))
    data = DOCUMENTS[name]
    paths = [p for p in nodes(data) if where(data, p)]
    assume(paths)
    return name, data, draw(st.sampled_from(paths))


def is_number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


# --- the two ways in: the loader and the command ---------------------------------------------

@contextlib.contextmanager
def scenario_file(content: bytes):
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "scenario.yaml"
        path.write_bytes(content)
        yield path, Path(folder) / "out"


def run_command(path: Path, out: Path) -> tuple[int | None, str]:
    """`python -m s3o_drake.run PATH --out OUT` in this process: its exit status (None when
    it passed validation and went on to the simulation's set-up) and its stderr."""
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()), \
            mock.patch("s3o_drake.commands.run_scenario.start_meshcat",
                       side_effect=ValidationPassedError):
        try:
            status = run_main([str(path), "--out", str(out)])
        except SystemExit as e:
            status = e.code
        except ValidationPassedError:
            status = None
    return status, err.getvalue()


def assert_bad_input(content: bytes) -> ScenarioError:
    """The file is bad input: the loader raises ScenarioError naming the file, and `run`
    says so in one line that names the file and the field, exits with 2 and writes
    nothing. Returns the loader's error."""
    with scenario_file(content) as (path, out):
        with pytest.raises(ScenarioError) as info:
            load_scenario(path)
        error = info.value
        assert error.file == str(path)
        assert error.path == "" or FIELD.match(error.path) or \
            re.fullmatch(r"line \d+", error.path), error.path
        status, err = run_command(path, out)
        assert status == 2, err
        assert err.count("\n") == 1 and err.endswith("\n"), err
        head = f"error: {path}: {error.path}: " if error.path else f"error: {path}: "
        assert err.startswith(head) and err.rstrip("\n") == f"error: {error}", err
        assert not out.exists()
    return error


def assert_valid_or_bad_input(content: bytes) -> None:
    """Either the file is bad input (as above, naming a field or a line) or it is valid,
    and `run` goes on to the simulation (or, without dishes, says there are none)."""
    with scenario_file(content) as (path, out):
        try:
            scenario = load_scenario(path)
        except ScenarioError:
            pass
        else:
            status, err = run_command(path, out)
            if scenario.dishes:
                assert status is None and err == "", err
            else:
                assert status == 2 and err.startswith(f"error: {path}: dishes: ")
            assert not out.exists()
            return
    assert_bad_input(content)


# --- the properties ----------------------------------------------------------------------------

def accepts_null(path: Path_) -> bool:
    """Whether the schema's field at `path` may be null: an optional field, whose value then
    comes from elsewhere (planner.reach: from the robot's description)."""
    kind: object = Scenario
    for key in path:
        kind = _one(kind)
        if dataclasses.is_dataclass(kind):
            kind = typing.get_type_hints(kind)[key]
        elif hasattr(kind, "__fields__"):  # Drake's config structs
            kind = {f.name: f.type for f in kind.__fields__}[key]
        else:  # a list or a mapping: its items' type
            kind = typing.get_args(kind)[-1]
    return type(None) in typing.get_args(kind)


def _one(kind: object) -> object:
    """`kind`, or the one type an optional `kind` holds when not null."""
    held = [k for k in typing.get_args(kind) if k is not type(None)]
    return held[0] if typing.get_args(kind) and len(held) == 1 and \
        type(None) in typing.get_args(kind) else kind


def _wrong_type(value) -> st.SearchStrategy:
    """Values that no field holding `value` accepts (an int written for a float field
    still rules out every non-number)."""
    text = st.text(max_size=12)
    scalars = st.one_of(st.none(), st.booleans(), text)
    if isinstance(value, bool):
        return st.one_of(st.none(), st.integers(), text, st.lists(st.integers(), max_size=3))
    if is_number(value):
        return st.one_of(scalars, st.lists(st.floats(-10, 10), max_size=3),
                         st.dictionaries(text, st.integers(), max_size=2))
    if isinstance(value, str):
        return st.one_of(st.none(), st.booleans(), st.integers(), st.floats(-10, 10),
                         st.lists(text, max_size=3))
    if isinstance(value, list):
        return st.one_of(scalars, st.integers(), st.dictionaries(text, st.integers(),
                                                                 max_size=2))
    return st.one_of(scalars, st.integers(), st.lists(st.integers(), max_size=3))


@EXAMPLES
@given(st.data())
def test_a_value_of_the_wrong_type_is_named(data):
    _, doc, path = data.draw(document())
    value = data.draw(_wrong_type(get(doc, path)))
    assume(path or value is not None)  # a file of `null` is an empty file: all defaults
    assume(value is not None or not accepts_null(path))
    error = assert_bad_input(dump(replaced(doc, path, value)))
    assert error.path == dotted(path)


def _extreme(path: Path_) -> st.SearchStrategy:
    """NaN, infinities and numbers too large to be meant (for the seed: beyond 64 bits or
    negative; 10^7 is a fine seed)."""
    special = st.sampled_from([float("nan"), float("inf"), float("-inf")])
    if path == ("seed",):
        return st.one_of(special, st.integers(min_value=2**63),
                         st.integers(max_value=-1), st.floats(1e7, 1e300))
    huge = st.floats(min_value=1e7, max_value=1e308)
    return st.one_of(special, huge, huge.map(lambda x: -x), st.integers(min_value=10**7),
                     st.integers(max_value=-(10**7)), st.integers(10**300, 10**400))


@EXAMPLES
@given(st.data())
def test_nan_infinity_and_huge_numbers_are_named(data):
    _, doc, path = data.draw(document(lambda d, p: is_number(get(d, p))))
    error = assert_bad_input(dump(replaced(doc, path, data.draw(_extreme(path)))))
    assert error.path == dotted(path)


KEYS = st.one_of(st.text(max_size=12), st.integers(), st.booleans(), st.none())


@EXAMPLES
@given(st.data())
def test_an_unknown_key_is_named(data):
    _, doc, path = data.draw(document(lambda d, p: isinstance(get(d, p), dict)))
    mapping = get(doc, path)
    # Near misses of the real keys (a typo, a capital, a hyphen) and anything else.
    near = st.sampled_from(sorted(mapping) or ["name"]).flatmap(lambda k: st.sampled_from(
        [k.upper(), k.capitalize(), k + "s", k + " ", k.replace("_", "-"), k[:-1]]))
    key = data.draw(st.one_of(near, KEYS))
    assume(key not in mapping and key not in _schema_fields(path))
    assume(key != "<<")  # YAML's merge key: a YAML error, named by its line
    error = assert_bad_input(dump(replaced(doc, path, {**mapping, key: 1})))
    assert within(error.path, dotted(path)) and "unknown field" in error.message


def _schema_fields(path: Path_) -> set[str]:
    """The fields of the dataclass at `path` (a key the base file leaves out is known)."""
    import dataclasses
    import typing

    from s3o_drake.world.scenario import Scenario

    schema = Scenario
    for part in path:
        if isinstance(part, str):
            schema = typing.get_type_hints(schema)[part]
        if typing.get_origin(schema) is list:
            (schema,) = typing.get_args(schema)
    return {f.name for f in dataclasses.fields(schema)}


@EXAMPLES
@given(st.data())
def test_a_key_given_twice_is_named(data):
    _, doc, path = data.draw(document(lambda d, p: isinstance(get(d, p), dict) and get(d, p)))
    key = data.draw(st.sampled_from(sorted(get(doc, path))))
    mapping = {**get(doc, path), PLACEHOLDER: data.draw(st.integers(0, 3))}
    text = dump(replaced(doc, path, mapping)).replace(PLACEHOLDER.encode(), key.encode())
    error = assert_bad_input(text)
    assert error.path == dotted((*path, key)) and "duplicate key" in error.message


def _named(doc) -> list[Path_]:
    """The named things in the order the validator reads them."""
    return [(kind, i) for kind in ("tables", "chairs", "dishes")
            for i in range(len(doc.get(kind) or []))]


@EXAMPLES
@given(st.data())
def test_a_duplicate_name_is_named(data):
    name = data.draw(st.sampled_from([n for n, d in DOCUMENTS.items() if len(_named(d)) > 1]))
    doc = DOCUMENTS[name]
    named = _named(doc)
    first, later = sorted(data.draw(st.lists(st.sampled_from(named), min_size=2, max_size=2,
                                             unique=True)), key=named.index)
    error = assert_bad_input(dump(replaced(doc, (*later, "name"),
                                           get(doc, (*first, "name")))))
    assert error.path == dotted((*later, "name")) and "duplicate name" in error.message


def _is_choice(doc, path: Path_) -> bool:
    """A string field whose values are restricted (names, references, kinds, methods...):
    every one but the output folder."""
    return isinstance(get(doc, path), str) and path != ("outputs", "directory")


@EXAMPLES
@given(st.data())
def test_unicode_in_a_name_or_a_choice_is_named(data):
    _, doc, path = data.draw(document(_is_choice))
    value = data.draw(st.text(min_size=1, max_size=12).filter(lambda s: not s.isascii()))
    text = dump(replaced(doc, path, value))
    assume(get(yaml.safe_load(text), path) == value)  # YAML keeps it as written
    error = assert_bad_input(text)
    assert error.path == dotted(path)


@EXAMPLES
@given(st.data(), st.integers(1, 3000), st.booleans())
def test_deep_nesting_is_named(data, depth, as_mappings):
    _, doc, path = data.draw(document())
    inner = yaml.safe_dump(get(doc, path), default_flow_style=True, width=10**9).strip()
    if inner.endswith("..."):  # a lone scalar's document end marker
        inner = inner[:-3].strip()
    nested = ("{a: " * depth + inner + "}" * depth) if as_mappings else \
        ("[" * depth + inner + "]" * depth)
    text = dump(replaced(doc, path, PLACEHOLDER)).replace(PLACEHOLDER.encode(),
                                                          nested.encode())
    error = assert_bad_input(text)
    assert within(error.path, dotted(path)), (error.path, dotted(path))


@EXAMPLES
@given(st.data())
def test_a_removed_key_or_item_is_its_default_or_named(data):
    _, doc, path = data.draw(document(lambda d, p: len(p) > 0))
    parent = copy.deepcopy(get(doc, path[:-1]))
    del parent[path[-1]]
    assert_valid_or_bad_input(dump(replaced(doc, path[:-1], parent)))


@EXAMPLES
@given(st.sampled_from(BASES), st.data())
def test_a_file_cut_short_is_valid_or_named(base, data):
    content = base.read_bytes()
    assert_valid_or_bad_input(content[:data.draw(st.integers(0, len(content)))])


# Bytes no UTF-8 text holds: continuation bytes alone, overlong starts, 0xF5..0xFF.
NOT_UTF8 = st.sampled_from([*range(0x80, 0xC2), *range(0xF5, 0x100)]).map(lambda b: bytes([b]))
# Text YAML does not allow: control characters.
CONTROL = st.sampled_from([*range(0x00, 0x09), 0x0B, 0x0C, *range(0x0E, 0x20), 0x7F]).map(
    lambda b: bytes([b]))


@EXAMPLES
@given(st.sampled_from(BASES), st.data(), st.one_of(NOT_UTF8, CONTROL), st.binary(max_size=8))
def test_bytes_that_are_not_text_name_the_line(base, data, bad, tail):
    content = base.read_bytes()
    at = data.draw(st.integers(0, len(content)))
    error = assert_bad_input(content[:at] + bad + tail + content[at:])
    # The first offending byte is the inserted one (the shipped files are clean ASCII)
    # or one of the random bytes after it.
    line = content[:at].count(b"\n") + 1
    assert error.path in {f"line {n}" for n in range(line, line + 10)}, error.path


def test_a_utf16_file_is_not_text():
    content = (REPO / "scenarios" / "small" / "two_dishes.yaml").read_text().encode("utf-16")
    error = assert_bad_input(content)
    assert error.path == "line 1" and "not UTF-8 text" in error.message


@pytest.mark.parametrize("content", [b"tables: " + b"[" * 5000 + b"]" * 5000 + b"\n",
                                     b"seed: 1\n\xff\xfe\n"],
                         ids=["nested 5000 deep", "not text"])
def test_the_command_in_its_own_process(tmp_path, content):
    path = tmp_path / "bad.yaml"
    path.write_bytes(content)
    out = tmp_path / "out"
    result = subprocess.run([sys.executable, "-m", "s3o_drake.run", str(path), "--out",
                             str(out)], capture_output=True, text=True, cwd=REPO, timeout=120)
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1 and result.stderr.startswith(f"error: {path}: ")
    assert result.stdout == "" and not out.exists()
