"""Reading YAML: the one loader of every YAML file the package reads, and typed values.

Every YAML file (randomisation specs, column-map sidecars, benchmark and agent configs, plant
presets, run folders' ``config.yml``) is read by :func:`load_yaml` (or :func:`load_yaml_text`),
which builds on ``yaml.SafeLoader`` (no Python tags: ``!!python/object`` is refused) and adds:

* a size limit, :data:`MAX_BYTES` (1 MB; the shipped files are below 10 kB);
* anchors and aliases are allowed (the agent configs share entries with ``<<: *default``), but
  the document they expand to is bounded: at most :data:`MAX_NODES` nodes, counting an alias at
  each of its uses, and no recursive alias. An "alias bomb" of a few hundred bytes that expands
  to billions of nodes is refused before it is constructed, in milliseconds;
* a key given twice in one mapping is an error naming the key and both lines (the last one no
  longer wins silently); keys merged in with ``<<`` are not duplicates, the mapping's own keys
  override them as YAML specifies;
* every error is one line of at most :data:`MAX_MESSAGE` characters naming the file, the line
  and column and the problem (:class:`YamlError`, a ``ValueError``).

Typed values (:func:`integer`, :func:`number`, :func:`boolean`, :func:`text`) check one field of
a loaded document and raise :class:`YamlError` naming the file, the field, the value and what is
allowed: an integer field refuses ``2.9`` and ``true``, a number field refuses booleans.
:func:`short` is the ``repr`` of a value cut to a readable length, for messages.
"""

from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Any

import yaml

__all__ = ["MAX_BYTES", "MAX_NODES", "MAX_MESSAGE", "YamlError", "load_yaml", "load_yaml_text", "short",
           "integer", "number", "boolean", "text"]

#: largest YAML file read [bytes]
MAX_BYTES = 1_000_000
#: largest document, in nodes after expanding every alias at each of its uses
MAX_NODES = 20_000
#: longest error message [characters]
MAX_MESSAGE = 300

_MERGE_TAG = "tag:yaml.org,2002:merge"


class YamlError(ValueError):
    """A YAML file that cannot be read as what it should be; ``path``, ``line`` and ``key`` locate it."""

    def __init__(self, path: Any, message: str, *, line: int | None = None, key: str | None = None) -> None:
        self.path = None if path is None else str(path)
        self.line = line
        self.key = key
        text = (f"{self.path}: " if self.path else "") + " ".join(str(message).split())
        if len(text) > MAX_MESSAGE:
            text = text[: MAX_MESSAGE - 3] + "..."
        super().__init__(text)


def short(value: Any, limit: int = 60) -> str:
    """``repr(value)`` cut to ``limit`` characters (a huge value in a message hides the message)."""
    r = repr(value)
    return r if len(r) <= limit else r[: limit - 3] + "..."


def _where(mark: Any) -> str:
    return "" if mark is None else f"line {mark.line + 1}, column {mark.column + 1}: "


def _check_graph(node: Any, path: Any, max_nodes: int) -> None:
    """Refuse a node graph that expands to more than ``max_nodes`` nodes, a recursive alias or a
    duplicate key. Each distinct node is visited once (its expanded size is memoised), so a
    bomb is measured without being expanded."""
    sizes: dict[int, int] = {}
    active: set[int] = set()
    stack: list[tuple[Any, bool]] = [(node, False)]
    while stack:
        n, done = stack.pop()
        key = id(n)
        if done:
            active.discard(key)
            children = _children(n)
            total = 1 + sum(sizes[id(c)] for c in children)
            sizes[key] = total
            if total > max_nodes:
                raise YamlError(path, f"{_where(n.start_mark)}the document expands to more than {max_nodes} nodes "
                                "(aliases counted at each use); refused (an alias bomb?)", line=n.start_mark.line + 1)
            continue
        if key in sizes:
            continue
        if key in active:
            raise YamlError(path, f"{_where(n.start_mark)}a recursive alias (a node that contains itself); refused",
                            line=n.start_mark.line + 1)
        active.add(key)
        if isinstance(n, yaml.MappingNode):
            _check_duplicates(n, path)
        stack.append((n, True))
        for c in _children(n):
            if id(c) not in sizes:
                stack.append((c, False))


def _children(n: Any) -> list[Any]:
    if isinstance(n, yaml.SequenceNode):
        return list(n.value)
    if isinstance(n, yaml.MappingNode):
        return [x for kv in n.value for x in kv]
    return []


def _check_duplicates(n: Any, path: Any) -> None:
    seen: dict[Any, int] = {}
    for k, _ in n.value:
        if not isinstance(k, yaml.ScalarNode) or k.tag == _MERGE_TAG:
            continue
        ident = (k.tag, k.value)
        line = k.start_mark.line + 1
        if ident in seen:
            raise YamlError(path, f"line {line}: duplicate key {short(k.value)} (first given on line {seen[ident]}); "
                            "each key may appear once in a mapping", line=line, key=str(k.value))
        seen[ident] = line


def load_yaml_text(text: str, source: Any = None, *, max_nodes: int = MAX_NODES) -> Any:
    """The document of YAML ``text`` (``source`` names it in errors); see the module docstring."""
    loader = yaml.SafeLoader(text)
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        _check_graph(node, source, max_nodes)
        return loader.construct_document(node)
    except YamlError:
        raise
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        what = f"not valid YAML: {exc.problem or exc.context or 'unreadable'}"
        if isinstance(exc, yaml.constructor.ConstructorError) and "could not determine a constructor" in str(what):
            what = f"{exc.problem} (only plain YAML is read: no Python or custom tags)"
        raise YamlError(source, f"{_where(mark)}{what}", line=None if mark is None else mark.line + 1) from None
    except yaml.YAMLError as exc:
        raise YamlError(source, f"not valid YAML: {exc}") from None
    finally:
        loader.dispose()


def load_yaml(path: Any, *, what: str = "YAML file", max_bytes: int = MAX_BYTES, max_nodes: int = MAX_NODES) -> Any:
    """The document of the YAML file ``path`` (a path or an ``importlib.resources`` Traversable).

    Raises :class:`YamlError` (one line: file, line, problem) for a missing or unreadable file,
    a file above ``max_bytes``, text that is not UTF-8, invalid YAML, a Python tag, a duplicate
    key or an expansion above ``max_nodes``. ``what`` names the file's role in messages.
    """
    p = Path(path) if isinstance(path, (str, os.PathLike)) else path
    try:
        if isinstance(p, Path):
            if not p.exists():
                raise YamlError(p, f"{what} not found")
            if not p.is_file():
                raise YamlError(p, f"{what} is not a regular file")
            size = p.stat().st_size
            if size > max_bytes:
                raise YamlError(p, f"{what} is {size} bytes; at most {max_bytes} are read")
        raw = p.read_bytes()
    except OSError as exc:
        raise YamlError(p, f"cannot read the {what}: {exc.strerror or exc}") from None
    if len(raw) > max_bytes:
        raise YamlError(p, f"{what} is {len(raw)} bytes; at most {max_bytes} are read")
    try:
        body = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise YamlError(p, f"{what} is not UTF-8 text (byte offset {exc.start}); a binary file?") from None
    return load_yaml_text(body, p, max_nodes=max_nodes)


# ---------------------------------------------------------------------------- typed values
def _fail(where: Any, field: str, value: Any, allowed: str) -> YamlError:
    return YamlError(where, f"{field} = {short(value)}; allowed {allowed}", key=field)


def _range(lo: float | None, hi: float | None) -> str:
    if lo is None and hi is None:
        return ""
    return f" in [{'-inf' if lo is None else f'{lo:g}'}, {'inf' if hi is None else f'{hi:g}'}]"


def integer(value: Any, field: str, where: Any = None, *, lo: int | None = None, hi: int | None = None) -> int:
    """``value`` as an int: an integer (an integral float such as ``2.0e+6`` too), not a bool,
    not ``2.9``, within ``[lo, hi]``."""
    allowed = "an integer" + _range(lo, hi)
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise _fail(where, field, value, allowed)
    if isinstance(value, float) and not (math.isfinite(value) and value == int(value)):
        raise _fail(where, field, value, allowed)
    v = int(value)
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        raise _fail(where, field, value, allowed)
    return v


def number(value: Any, field: str, where: Any = None, *, lo: float | None = None, hi: float | None = None) -> float:
    """``value`` as a finite float within ``[lo, hi]``; a bool is refused, a numeric string
    (YAML 1.1 reads ``3e-4`` as one) is accepted."""
    allowed = "a finite number" + _range(lo, hi)
    v = value
    if isinstance(v, str):
        try:
            v = float(v)
        except ValueError:
            raise _fail(where, field, value, allowed) from None
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise _fail(where, field, value, allowed)
    v = float(v)
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        raise _fail(where, field, value, allowed)
    return v


def boolean(value: Any, field: str, where: Any = None) -> bool:
    """``value`` if it is ``true`` or ``false`` (not 1, 0 or a string)."""
    if not isinstance(value, bool):
        raise _fail(where, field, value, "true or false")
    return value


def text(value: Any, field: str, where: Any = None, *, choices: tuple[str, ...] | None = None) -> str:
    """``value`` if it is a string (one of ``choices`` when given)."""
    if not isinstance(value, str) or (choices is not None and value not in choices):
        raise _fail(where, field, value, "a string" if choices is None else ", ".join(choices))
    return value
