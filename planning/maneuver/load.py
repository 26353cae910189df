"""Reading maneuvers: YAML text or files → `Maneuver`, pydantic errors → plain `Problem`s, library lookup."""

from __future__ import annotations

import difflib
import json
import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, get_args

import numpy as np
import yaml
from pydantic import BaseModel, ValidationError

from planning.maneuver.problems import ManeuverError, Problem, with_lines
from planning.maneuver.spec import FORMAT, NAME_PATTERN, Maneuver

SHIPPED_LIBRARY = Path(__file__).resolve().parents[2] / "maneuvers"
MAX_TEXT_BYTES = 1_000_000  # a maneuver file is a few kB; refuse megabytes before parsing them


# ---- YAML ----------------------------------------------------------------------------------------------------
MAX_NESTING = 32  # a maneuver nests 4 levels deep; deeper documents are refused before they are built
MAX_LIST_LENGTH = (
    2000  # the longest list of a maneuver (events); counted while reading, before anything is built
)


class _Loader(yaml.SafeLoader):
    """SafeLoader that refuses duplicate keys, aliases and deep nesting, reads `1e-4` as a number (YAML 1.2 style)
    and reports a value its tag cannot make (a date like 2001-13-45, `!!int abc`, a 5000-digit integer) as a YAML
    error at the value's line instead of a bare ValueError.

    Aliases are refused because a few nested ones expand into billions of items for the validator to walk; nesting
    and list lengths are counted while composing, so a 20k-event file stops at item 2001 instead of being read
    whole and checked item by item (flow brackets are counted even before that: see `flow_depth`).
    """

    _depth = 0

    def compose_node(self, parent: yaml.Node | None, index: Any) -> yaml.Node | None:
        if self.check_event(yaml.AliasEvent):
            mark = self.peek_event().start_mark
            raise yaml.composer.ComposerError(
                None, None, "aliases (*name) are not allowed in a maneuver file; write the value out", mark
            )
        if self._depth >= MAX_NESTING:
            mark = self.peek_event().start_mark
            raise yaml.composer.ComposerError(
                None, None, f"nests more than {MAX_NESTING} levels deep; a maneuver needs a few", mark
            )
        if isinstance(parent, yaml.SequenceNode) and isinstance(index, int) and index >= MAX_LIST_LENGTH:
            mark = self.peek_event().start_mark
            raise yaml.composer.ComposerError(
                None,
                None,
                f"a list of more than {MAX_LIST_LENGTH} items; no list of a maneuver is that long",
                mark,
            )
        self._depth += 1
        try:
            return super().compose_node(parent, index)  # type: ignore[no-untyped-call]
        finally:
            self._depth -= 1

    def construct_object(self, node: yaml.Node, deep: bool = False) -> Any:
        try:
            return super().construct_object(node, deep=deep)  # type: ignore[no-untyped-call]
        except (ValueError, OverflowError, TypeError) as e:
            tag = str(node.tag).rsplit(":", 1)[-1]
            shown = str(node.value)[:40] + ("..." if len(str(node.value)) > 40 else "")
            why = str(e).split("\n", 1)[0][:120]
            raise yaml.constructor.ConstructorError(
                None, None, f"cannot read {shown!r} as {tag} ({why})", node.start_mark
            ) from None

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        seen: dict[Any, yaml.Node] = {}
        for key_node, _ in node.value:
            key = self.construct_object(key_node, deep=deep)
            try:
                duplicate = key in seen
            except TypeError:  # an unhashable key; the base class reports it
                break
            if duplicate:
                raise yaml.constructor.ConstructorError(
                    "while reading a mapping",
                    node.start_mark,
                    f"found duplicate key {key!r}",
                    key_node.start_mark,
                )
            seen[key] = key_node
        return super().construct_mapping(node, deep=deep)


_Loader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?[0-9][0-9_]*(?:\.[0-9_]*)?[eE][-+]?[0-9]+$"),
    list("-+0123456789"),
)


def _yaml_problem(e: yaml.YAMLError) -> Problem:
    if isinstance(e, yaml.MarkedYAMLError) and e.problem_mark is not None:
        mark = e.problem_mark
        what = e.problem or "syntax error"
        ctx = f" ({e.context})" if e.context else ""
        syntax = isinstance(e, (yaml.scanner.ScannerError, yaml.parser.ParserError))
        kind = "YAML syntax error" if syntax else "YAML error"
        return Problem(
            "",
            f"{kind} at line {mark.line + 1}, column {mark.column + 1}: {what}{ctx}",
            line=mark.line + 1,
        )
    return Problem("", f"YAML syntax error: {e}")


def _line_map(node: yaml.Node | None, path: str = "", out: dict[str, int] | None = None) -> dict[str, int]:
    """Returns field path → 1-based line for every node of a composed YAML document."""
    out = {} if out is None else out
    if node is None:
        return out
    out.setdefault(path, node.start_mark.line + 1)
    if isinstance(node, yaml.MappingNode):
        for k, v in node.value:
            if isinstance(k, yaml.ScalarNode):
                child = f"{path}.{k.value}" if path else str(k.value)
                out.setdefault(child, k.start_mark.line + 1)
                _line_map(v, child, out)
    elif isinstance(node, yaml.SequenceNode):
        for i, v in enumerate(node.value):
            _line_map(v, f"{path}[{i}]", out)
    return out


_QUOTED_OR_COMMENT = re.compile(
    r'"(?:[^"\\\n]|\\.)*"|\'(?:[^\'\n]|\'\')*\'|(?:^|(?<=\s))#[^\n]*', re.MULTILINE
)


def flow_depth(text: str) -> tuple[int, int]:
    """Returns (deepest nesting of flow brackets [ { outside quotes and comments, its offset in `text`).

    Vectorized (a few ms for 1 MB): the YAML scanner looks ahead over every open bracket for each token, so a
    document of nothing but `[` costs it seconds; counting first refuses such a document before it is parsed.
    """
    bare = _QUOTED_OR_COMMENT.sub(lambda m: " " * len(m.group()), text)
    codes = np.frombuffer(bare.encode("utf-32-le"), dtype=np.uint32)
    step = np.isin(codes, (0x5B, 0x7B)).astype(np.int32) - np.isin(codes, (0x5D, 0x7D)).astype(np.int32)
    if not step.any():
        return 0, 0
    level = np.concatenate(([0], np.cumsum(step)))
    depth = level - np.minimum.accumulate(level)  # a stray closer does not hide the openers after it
    i = int(np.argmax(depth))
    return int(depth[i]), max(0, i - 1)


def read_yaml(text: str) -> tuple[Any, dict[str, int]]:
    """Returns (data, path → line map) of YAML text; raises ManeuverError with line and column on bad syntax,
    a value that cannot be read, or nesting deeper than MAX_NESTING."""
    if len(text.encode("utf-8", "replace")) > MAX_TEXT_BYTES:
        raise ManeuverError(
            [Problem("", f"the file is larger than {MAX_TEXT_BYTES // 1000} kB; not a maneuver")]
        )
    depth, at = flow_depth(text)
    if depth > MAX_NESTING:
        line = text.count("\n", 0, at) + 1
        raise ManeuverError(
            [
                Problem(
                    "",
                    f"YAML error at line {line}: brackets nest more than {MAX_NESTING} levels deep; "
                    "a maneuver needs a few",
                    line=line,
                )
            ]  # fmt: skip
        )
    try:
        loader = _Loader(text)  # the reader refuses control characters here, before any parsing
    except yaml.YAMLError as e:
        raise ManeuverError([_yaml_problem(e)]) from None
    try:
        node = loader.get_single_node()  # type: ignore[no-untyped-call]
        data = loader.construct_document(node) if node is not None else None  # type: ignore[no-untyped-call]
    except yaml.YAMLError as e:
        raise ManeuverError([_yaml_problem(e)]) from None
    except RecursionError:
        raise ManeuverError([Problem("", "the YAML nests too deeply")]) from None
    finally:
        loader.dispose()  # type: ignore[no-untyped-call]
    return data, _line_map(node)


# ---- pydantic errors → problems --------------------------------------------------------------------------------
def _models_in(annotation: Any) -> list[type[BaseModel]]:
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return [annotation]
    return [m for a in get_args(annotation) for m in _models_in(a)]


def _tag_of(model: type[BaseModel]) -> str | None:
    field = model.model_fields.get("type")
    args = get_args(field.annotation) if field is not None else ()
    return str(args[0]) if args else None


def _field(model: type[BaseModel], key: str) -> Any:
    for name, f in model.model_fields.items():
        if key in (name, f.alias):
            return f
    return None


def _walk_loc(loc: tuple[str | int, ...]) -> tuple[str, type[BaseModel] | None]:
    """Returns (field path like `events[3].t`, the model that holds the last field) for a pydantic error loc.

    Pydantic puts the tag of a discriminated union into the loc (`events, 3, touchdown, t`); the file has no such
    level, so tags are dropped from the path.
    """
    parts: list[str] = []
    model: type[BaseModel] | None = Maneuver
    parent: type[BaseModel] | None = Maneuver
    union: list[type[BaseModel]] = []
    for item in loc:
        if isinstance(item, int):
            parts.append(f"[{item}]")
            continue
        tagged = next((m for m in union if _tag_of(m) == item), None)
        if tagged is not None:
            model, union = tagged, []
            continue
        parts.append(f".{item}" if parts else str(item))
        parent = model
        f = _field(model, item) if model is not None else None
        found = _models_in(f.annotation) if f is not None else []
        model, union = (found[0], []) if len(found) == 1 else (None, found)
    return "".join(parts), parent


def _show(value: Any) -> str:
    try:
        text = json.dumps(value, default=str)
    except (TypeError, ValueError):
        text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def _fields_of(model: type[BaseModel] | None) -> list[str]:
    if model is None:
        return []
    return [f.alias or name for name, f in model.model_fields.items()]


_BOUNDS = {
    "greater_than": ("greater than", "gt"),
    "greater_than_equal": ("at least", "ge"),
    "less_than": ("less than", "lt"),
    "less_than_equal": ("at most", "le"),
}
_TIME_FIELDS = {"t", "duration", "from", "to", "cycle", "time"}


def _message(err: Any, parent: type[BaseModel] | None, path: str) -> str:
    kind, ctx, value = err["type"], err.get("ctx") or {}, err.get("input")
    field = path.rsplit(".", 1)[-1]
    if kind == "missing":
        if path == "format":
            return f"is required: start the file with `format: {FORMAT}`"
        return "is required"
    if kind == "extra_forbidden":
        allowed = _fields_of(parent)
        close = difflib.get_close_matches(field, allowed, n=1)
        hint = f"; did you mean {close[0]!r}?" if close else ""
        return (
            f"unknown field{hint} (allowed here: {', '.join(allowed)})" if allowed else f"unknown field{hint}"
        )
    if kind == "literal_error":
        if field == "leg":
            return f"unknown leg {_show(value)}; legs are FL, FR, RL, RR"
        if path == "format":
            return f"must be {FORMAT}, got {_show(value)}"
        return f"must be one of {ctx.get('expected', '')}, got {_show(value)}"
    if kind == "union_tag_invalid":
        return f"unknown type {_show(ctx.get('tag'))}; expected one of {ctx.get('expected_tags', '')}"
    if kind == "union_tag_not_found":
        kinds = (
            "maximize_height, lean or minimize_torque"
            if path.startswith("objectives")
            else "liftoff or touchdown"
        )
        return f"is required: {kinds}"
    if kind in ("model_type", "model_attributes_type", "dict_type"):
        return f"must be a mapping of fields (key: value), got {_show(value)}"
    if kind in ("tuple_type", "list_type"):
        return f"must be a list, got {_show(value)}"
    if kind in ("float_type", "float_parsing", "int_type", "int_parsing"):
        return f"must be a number, got {_show(value)}"
    if kind == "finite_number":
        return f"must be a finite number, got {_show(value)}"
    if kind in _BOUNDS:
        words, key = _BOUNDS[kind]
        unit = " s" if field in _TIME_FIELDS or re.fullmatch(r"t\[\d\]", field) else ""
        return f"must be {words} {ctx.get(key, 0):g}{unit}, got {_show(value)}"
    if kind == "string_type":
        return f"must be text, got {_show(value)}"
    if kind == "string_pattern_mismatch" and ctx.get("pattern") == NAME_PATTERN:
        return (
            f"must be lowercase letters, digits and single dashes (like reach-and-lean), got {_show(value)}"
        )
    if kind == "string_too_long":
        return f"is too long (at most {ctx.get('max_length')} characters)"
    msg = str(err.get("msg", "is invalid"))
    for prefix in ("Value error, ", "Assertion failed, "):
        msg = msg.removeprefix(prefix)
    return msg[:1].lower() + msg[1:]


def problems_from_validation_error(e: ValidationError) -> list[Problem]:
    """Returns one plain Problem per pydantic error, with file-style field paths."""
    out = []
    for err in e.errors(include_url=False):
        path, parent = _walk_loc(tuple(err["loc"]))
        if err["type"] in ("union_tag_invalid", "union_tag_not_found"):
            path = f"{path}.type"
        out.append(Problem(path, _message(err, parent, path)))
    return out


# ---- public entry points ---------------------------------------------------------------------------------------
MAX_LIST_ITEMS = {"events": 2000, "body": 500, "gaits": 100, "objectives": 100}  # events: expand.MAX_EVENTS


def _too_many_items(data: dict[Any, Any]) -> list[Problem]:
    """Returns a problem per list longer than its limit, found before any item is validated (a 20k-event file
    is refused at once instead of being checked item by item first)."""
    out = []
    for key, limit in MAX_LIST_ITEMS.items():
        items = data.get(key)
        if isinstance(items, (list, tuple)) and len(items) > limit:
            out.append(Problem(key, f"has {len(items)} items; at most {limit} are allowed"))
    return out


def parse_maneuver(data: Any, *, lines: dict[str, int] | None = None, source: str | None = None) -> Maneuver:
    """Returns the Maneuver of a parsed document (a dict); raises ManeuverError listing every shape problem."""
    if isinstance(data, Maneuver):
        return data
    if not isinstance(data, dict):
        kind = "empty" if data is None else f"a {type(data).__name__}"
        raise ManeuverError(
            [
                Problem(
                    "", f"a maneuver must be a mapping of fields (format, name, duration, ...), got {kind}"
                )
            ],
            source,
        )
    too_many = _too_many_items(data)
    if too_many:
        raise ManeuverError(with_lines(too_many, lines), source)
    try:
        return Maneuver.model_validate(data)
    except ValidationError as e:
        raise ManeuverError(with_lines(problems_from_validation_error(e), lines), source) from None
    except RecursionError:
        raise ManeuverError([Problem("", "the document nests too deeply")], source) from None


def _looks_like_path(s: str) -> bool:
    """Whether a string names a file rather than holding YAML text: one line ending in .yaml/.yml, no mapping."""
    return (
        "\n" not in s and s.endswith((".yaml", ".yml")) and ": " not in s and "{" not in s and len(s) < 4096
    )


def read_source(source: str | Path) -> tuple[Any, dict[str, int], str | None]:
    """Returns (parsed document, path → line map, file name or None) of a file path or YAML text."""
    name: str | None = None
    if isinstance(source, Path) or _looks_like_path(source):
        path = Path(source)
        name = str(path)
        try:
            size = path.stat().st_size
            if size > MAX_TEXT_BYTES:  # checked before reading: a 50 MB file is not read at all
                raise ManeuverError(
                    [Problem("", f"the file is {size / 1e6:.1f} MB, larger than {MAX_TEXT_BYTES // 1000} kB; "
                                 "not a maneuver")], name)  # fmt: skip
            text = path.read_text(encoding="utf-8")
        except FileNotFoundError:
            raise ManeuverError([Problem("", f"no such file: {path}")]) from None
        except (OSError, UnicodeDecodeError) as e:
            raise ManeuverError([Problem("", f"cannot read {path}: {e}")]) from None
    else:
        text = source
    try:
        data, lines = read_yaml(text)
    except ManeuverError as e:
        raise ManeuverError(e.problems, name) from None
    return data, lines, name


def load_maneuver(source: str | Path | dict[str, Any] | Maneuver) -> Maneuver:
    """Returns the Maneuver of a file path, YAML text, a dict or a Maneuver; raises ManeuverError.

    Only the shape is checked here; `validate_maneuver` checks the rules that relate fields to each other.
    """
    if not isinstance(source, (str, Path)):
        return parse_maneuver(source)
    data, lines, name = read_source(source)
    return parse_maneuver(data, lines=lines, source=name)


def find_maneuver(
    name_or_path: str | Path,
    library_dirs: Sequence[str | Path] = (SHIPPED_LIBRARY,),
    *,
    allow_paths: bool = True,
) -> Path:
    """Returns the file of a maneuver given by library name (first directory wins) or, if allowed, by path.

    A name must match the format's name pattern, so a name never reaches outside the library directories; servers
    pass ``allow_paths=False``.
    """
    s = str(name_or_path)
    if allow_paths and (isinstance(name_or_path, Path) or "/" in s or s.endswith((".yaml", ".yml"))):
        p = Path(s)
        if p.is_file():
            return p
        raise ManeuverError([Problem("", f"no such file: {p}")])
    if not re.fullmatch(NAME_PATTERN, s) or len(s) > 64:
        raise ManeuverError(
            [Problem("", f"{s!r} is not a maneuver name (lowercase letters, digits and single dashes)")]
        )
    for d in library_dirs:
        for ext in (".yaml", ".yml"):
            p = Path(d) / f"{s}{ext}"
            if p.is_file():
                return p
    known = sorted({p.stem for d in library_dirs if Path(d).is_dir() for p in Path(d).glob("*.y*ml")})
    close = difflib.get_close_matches(s, known, n=3)
    hint = f"; did you mean {', '.join(close)}?" if close else f" (library: {', '.join(known) or 'empty'})"
    raise ManeuverError([Problem("", f"no maneuver named {s!r}{hint}")])


@dataclass(frozen=True)
class LibraryEntry:
    """One file of a maneuver library: its name, title and duration, or why it does not load."""

    name: str
    path: Path
    title: str | None = None
    duration_s: float | None = None
    problems: tuple[Problem, ...] = ()


def list_library(library_dirs: Sequence[str | Path] = (SHIPPED_LIBRARY,)) -> list[LibraryEntry]:
    """Returns the maneuvers of the library directories sorted by name; an earlier directory shadows a later one."""
    entries: dict[str, LibraryEntry] = {}
    for d in library_dirs:
        if not Path(d).is_dir():
            continue
        for p in sorted(Path(d).glob("*.y*ml")):
            if p.stem in entries or p.suffix not in (".yaml", ".yml"):
                continue
            try:
                m = load_maneuver(p)
            except ManeuverError as e:
                entries[p.stem] = LibraryEntry(p.stem, p, problems=tuple(e.problems))
                continue
            entries[p.stem] = LibraryEntry(m.name, p, m.title, m.duration)
    return [entries[k] for k in sorted(entries)]
