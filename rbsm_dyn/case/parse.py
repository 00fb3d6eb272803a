"""YAML 1.2 text -> plain Python (dicts, lists, numbers, strings) and the
line of every key and list item; every problem is a :class:`CaseError`."""
from __future__ import annotations

import datetime
import re
import warnings
from typing import Any, Optional

from ruamel.yaml import YAML
from ruamel.yaml.comments import CommentedMap, CommentedSeq, TaggedScalar
from ruamel.yaml.constructor import RoundTripConstructor
from ruamel.yaml.error import MarkedYAMLError, YAMLError
from ruamel.yaml.nodes import MappingNode, ScalarNode, SequenceNode

from .errors import CaseError, KeyPath, _nearest_line, _show


_CORE_TAGS = {f"tag:yaml.org,2002:{t}" for t in
              ("str", "int", "float", "bool", "null", "map", "seq", "timestamp")}



#: Values that YAML aliases (``*name``) may add to a document in all: enough
#: to reuse a material or a table many times, not enough for an alias bomb
#: (nested aliases that expand to 10⁹ values from a few lines of text).
MAX_ALIAS_VALUES = 100_000

_NON_CORE = {"CommentedSet": "!!set"}


class _NodeProblem(Exception):
    """Raised by the node check: (line, key path, message)."""


def _check_nodes(root, paths: dict) -> None:
    """Before anything is constructed: keys are scalars, no alias refers to
    a collection that contains it, and aliases add at most
    ``MAX_ALIAS_VALUES`` values (sizes memoised per node: linear time).
    ``paths`` gets the key path of every node (id -> path)."""
    size: dict[int, int] = {}
    active: set[int] = set()
    seen: set[int] = set()            # distinct nodes (values and keys) met so far
    stack = [(root, (), False)]
    while stack:                      # iterative post-order (no recursion limit)
        node, path, done = stack.pop()
        paths.setdefault(id(node), path)
        seen.add(id(node))
        if not isinstance(node, (MappingNode, SequenceNode)):
            continue
        key = id(node)
        line = node.start_mark.line + 1
        if done:
            active.discard(key)
            kids = (node.value if isinstance(node, SequenceNode)
                    else [n for pair in node.value for n in pair])
            size[key] = 1 + sum(size.get(id(k), 1) for k in kids)
            # values this collection expands to, less the distinct nodes met
            # so far (all of its own among them): at most what aliases add,
            # and exactly that at the root; a long plain list adds nothing
            if size[key] - len(seen) > MAX_ALIAS_VALUES:
                raise _NodeProblem(line, path, "aliases (*name) expand to more than "
                                   f"{MAX_ALIAS_VALUES} values (nested aliases: an alias bomb?)")
            continue
        if key in size:
            continue
        if key in active:
            raise _NodeProblem(line, path, "an alias refers to a list or mapping that contains it")
        active.add(key)
        stack.append((node, path, True))
        if isinstance(node, MappingNode):
            kids = []
            for k, v in node.value:
                if not isinstance(k, ScalarNode):
                    what = "a list" if isinstance(k, SequenceNode) else "a mapping"
                    raise _NodeProblem(k.start_mark.line + 1, path,
                                       f"keys must be plain names (got {what} as a key)")
                seen.add(id(k))
                kids.append((v, path + (str(k.value),), False))
        else:
            kids = [(v, path + (i,), False) for i, v in enumerate(node.value)]
        stack.extend(reversed(kids))      # visited in document order


class _CheckedConstructor(RoundTripConstructor):
    """The round-trip constructor, after ``_check_nodes`` on the node tree; a
    value its tag cannot make (``!!bool 'x'``, ``!!int 1.5``) is a _NodeProblem."""

    def construct_document(self, node):
        self._node_paths: dict = {}
        _check_nodes(node, self._node_paths)
        return super().construct_document(node)

    def construct_object(self, node, deep=False):
        try:
            return super().construct_object(node, deep=deep)
        except (YAMLError, _NodeProblem, RecursionError):
            raise
        except Exception:
            tag = str(getattr(node.tag, "value", node.tag)).replace("tag:yaml.org,2002:", "!!")
            value = node.value if isinstance(node, ScalarNode) else "this value"
            raise _NodeProblem(node.start_mark.line + 1,
                               getattr(self, "_node_paths", {}).get(id(node), ()),
                               f"cannot read {value!r} as {tag}") from None


def _plain(node: Any, path: KeyPath, lines: dict, file: str) -> Any:
    """Copy the ruamel tree into plain Python, recording lines in ``lines``."""
    def bad_tag(tag: str) -> CaseError:
        tag = tag.replace("tag:yaml.org,2002:", "!!")
        return CaseError(file, _nearest_line(lines, path), path,
                         f"tag {tag} is not allowed (plain YAML values only)")

    if isinstance(node, TaggedScalar):
        if node.tag.value == "tag:yaml.org,2002:str":
            return str(node.value)
        raise bad_tag(node.tag.value)
    tag = getattr(getattr(node, "tag", None), "value", None)
    if tag is not None and tag not in _CORE_TAGS and isinstance(
            node, (CommentedMap, CommentedSeq)):
        raise bad_tag(tag)
    if isinstance(node, dict):
        out = {}
        for key in node:
            k = _plain(key, path, lines, file)
            try:
                lines[path + (k,)] = node.lc.key(key)[0] + 1
            except (KeyError, AttributeError, TypeError):
                pass  # merged (<<) keys have no line of their own
            out[k] = _plain(node[key], path + (k,), lines, file)
        return out
    if isinstance(node, list):
        for i in range(len(node)):
            try:
                lines[path + (i,)] = node.lc.item(i)[0] + 1
            except (KeyError, AttributeError, TypeError):
                pass
        return [_plain(v, path + (i,), lines, file) for i, v in enumerate(node)]
    if isinstance(node, bool) or type(node).__name__ == "ScalarBoolean":
        return bool(node)
    if isinstance(node, int):
        return int(node)
    if isinstance(node, float):
        return float(node)
    if isinstance(node, str):
        return str(node)
    if isinstance(node, (datetime.date, datetime.datetime)):
        return node.isoformat()
    if node is None:
        return None
    raise bad_tag("!!binary" if isinstance(node, bytes)
                  else _NON_CORE.get(type(node).__name__, type(node).__name__))


#: Deepest nesting of flow collections ([...] and {...}) read: ruamel's scanner
#: takes quadratic time in it (20 s at 1000) and recursion ends near 300.
MAX_FLOW_DEPTH = 64


def _flow_depth_line(text: str) -> Optional[int]:
    """Line where brackets nest deeper than MAX_FLOW_DEPTH, or None.  Brackets
    in quoted strings and comments count too: an upper bound."""
    depth, line = 0, 1
    for m in re.finditer(r"[\[\]{}\n]", text):
        c = m.group()
        if c == "\n":
            line += 1
        elif c in "[{":
            depth += 1
            if depth > MAX_FLOW_DEPTH:
                return line
        else:
            depth = max(0, depth - 1)
    return None


def _parse(text: str, file: str) -> tuple[dict, dict]:
    """YAML text -> (plain dict, {key path: line})."""
    deep = _flow_depth_line(text)
    if deep is not None:
        raise CaseError(file, deep, (), "YAML error: lists or mappings nested more than "
                        f"{MAX_FLOW_DEPTH} deep")
    yaml = YAML(typ="rt")
    yaml.Constructor = _CheckedConstructor
    yaml.allow_duplicate_keys = False
    try:
        with warnings.catch_warnings():   # e.g. a reused anchor: YAML allows it
            warnings.simplefilter("ignore")
            root = yaml.load(text)
    except _NodeProblem as ex:
        raise CaseError(file, *ex.args) from None
    except MarkedYAMLError as ex:
        mark = ex.problem_mark or ex.context_mark
        line = mark.line + 1 if mark is not None else None
        what = ex.problem or ex.context or "invalid YAML"
        if "duplicate key" in what:
            what = what.split(" with value")[0]
        raise CaseError(file, line, (), f"YAML error: {what}") from None
    except YAMLError as ex:
        mark = getattr(ex, "problem_mark", None) or getattr(ex, "mark", None)
        line = mark.line + 1 if getattr(mark, "line", None) is not None else None
        position = getattr(ex, "position", None)  # ReaderError: bad character
        if line is None and isinstance(position, int):
            line = text[:position].count("\n") + 1
        msg = str(ex).splitlines()[0] if str(ex) else type(ex).__name__
        raise CaseError(file, line, (), f"YAML error: {msg}") from None
    except RecursionError:
        raise CaseError(file, 1, (), "YAML error: lists or mappings nested too deeply") from None
    if root is None:
        raise CaseError(file, 1, (), "the case file is empty")
    lines: dict = {}
    if isinstance(root, (CommentedMap, CommentedSeq)):
        lines[()] = root.lc.line + 1
    if not isinstance(root, dict):
        raise CaseError(file, lines.get((), 1), (),
                        f"the top level must be a mapping of keys (got {_show(root)})")
    try:
        return _plain(root, (), lines, file), lines
    except RecursionError:
        raise CaseError(file, 1, (), "YAML error: lists or mappings nested too deeply") from None
