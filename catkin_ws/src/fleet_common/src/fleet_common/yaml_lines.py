"""YAML that remembers where each value came from, for errors that name a line.

`load_marked` reads YAML (safe subset) into plain dicts and lists that also
carry `mark` (their own (line, column), 1-based) and `marks` (key or index ->
(line, column) of that value). `where(data, key)` looks a position up, so a
checker can say "frames.yaml:7:10: scale must be positive". Duplicate keys,
which PyYAML silently lets the last one win, are an error here, and so are
integers of more than MAX_INT_DIGITS digits (PyYAML would raise a bare
ValueError past 4,300) and nesting deeper than Python's recursion allows.
`read_yaml_text` reads a file of at most MAX_YAML_BYTES.
"""
from __future__ import annotations

from typing import Any, Dict, Optional, Tuple, Type

import yaml

from .errors import FormatError
from .limits import MAX_INT_DIGITS, MAX_YAML_BYTES, excerpt, one_line

Mark = Tuple[int, int]


class MarkedDict(dict):
    mark: Mark
    marks: Dict[Any, Mark]


class MarkedList(list):
    mark: Mark
    marks: Dict[int, Mark]


class _Refused(Exception):
    def __init__(self, message: str, mark: Mark) -> None:
        super().__init__(message)
        self.mark = mark


def _mark(node: yaml.Node) -> Mark:
    return (node.start_mark.line + 1, node.start_mark.column + 1)


class _Loader(yaml.SafeLoader):
    def construct_marked_map(self, node: yaml.MappingNode) -> MarkedDict:
        self.flatten_mapping(node)
        out = MarkedDict()
        out.mark, out.marks = _mark(node), {}
        key_lines: Dict[Any, int] = {}
        for key_node, value_node in node.value:
            key = self.construct_object(key_node, deep=True)
            if isinstance(key, (dict, list)):
                raise _Refused("a key must be a plain value, not a mapping or list",
                                 _mark(key_node))
            if key in out:
                raise _Refused("duplicate key {} (first on line {})".format(
                    excerpt(key), key_lines[key]), _mark(key_node))
            key_lines[key] = _mark(key_node)[0]
            out[key] = self.construct_object(value_node, deep=True)
            out.marks[key] = _mark(value_node)
        return out

    def construct_bounded_int(self, node: yaml.ScalarNode) -> int:
        text = str(node.value).replace("_", "").lstrip("+-")
        if len(text) > MAX_INT_DIGITS + 2:  # + 2: a 0x or 0o prefix
            raise _Refused("integer of {:,} digits; at most {} are allowed".format(
                len(text), MAX_INT_DIGITS), _mark(node))
        return super().construct_yaml_int(node)

    def construct_marked_seq(self, node: yaml.SequenceNode) -> MarkedList:
        out = MarkedList(self.construct_object(child, deep=True) for child in node.value)
        out.mark, out.marks = _mark(node), {i: _mark(c) for i, c in enumerate(node.value)}
        return out


_Loader.add_constructor("tag:yaml.org,2002:map", _Loader.construct_marked_map)
_Loader.add_constructor("tag:yaml.org,2002:seq", _Loader.construct_marked_seq)
_Loader.add_constructor("tag:yaml.org,2002:int", _Loader.construct_bounded_int)


def load_marked(text: str, path: Optional[str] = None,
                error: Type[FormatError] = FormatError) -> Any:
    """The YAML document in `text` (None if empty); malformed YAML raises `error`."""
    try:
        return yaml.load(text, Loader=_Loader)
    except yaml.MarkedYAMLError as err:
        mark = err.problem_mark or err.context_mark
        line, column = (mark.line + 1, mark.column + 1) if mark else (None, None)
        raise error("not valid YAML: {}".format(err.problem or err.context),
                    path, line, column) from None
    except yaml.YAMLError as err:
        raise error("not valid YAML: {}".format(one_line(str(err), 200)), path) from None
    except _Refused as err:
        raise error(str(err), path, *err.mark) from None
    except RecursionError:
        raise error("not valid YAML here: nested too deep", path) from None


def read_yaml_text(path: str, error: Type[FormatError] = FormatError) -> str:
    """A YAML file's text: at most MAX_YAML_BYTES, UTF-8 (a bad byte is an error naming it)."""
    from .formats.lines import read_text

    return read_text(path, error, MAX_YAML_BYTES, strict=True)


def where(data: Any, key: Any = None) -> Tuple[Optional[int], Optional[int]]:
    """(line, column) of `data[key]`, else of `data`, else (None, None) for plain data."""
    marks = getattr(data, "marks", None) or {}
    if key is not None and key in marks:
        return marks[key]
    return getattr(data, "mark", None) or (None, None)
