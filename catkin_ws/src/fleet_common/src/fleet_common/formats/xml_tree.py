"""XML elements that know their line: a small tree built with expat.

`xml.etree` forgets where elements were; every FleetControl error names a
line, so `parse_xml` records expat's line and column for each start tag, and
`AttributeReader` turns attributes into numbers with errors that point there.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Dict, List, Optional, Type, Union
from xml.parsers import expat

from ..errors import FormatError

_INT = re.compile(r"[+-]?[0-9]+\Z")


@dataclass
class Element:
    """An XML element with the line and column (1-based) where its start tag begins."""

    tag: str
    attrs: Dict[str, str]
    line: int
    column: int
    children: List["Element"] = field(default_factory=list)

    def iter(self) -> "List[Element]":
        """This element and all below it, in document order."""
        out = [self]
        for child in self.children:
            out.extend(child.iter())
        return out


def parse_xml(data: Union[str, bytes], path: Optional[str] = None,
              error: Type[FormatError] = FormatError) -> Element:
    """The document's root element; malformed XML raises `error` with line and column."""
    parser = expat.ParserCreate()
    stack: List[Element] = []
    roots: List[Element] = []

    def start(tag: str, attrs: Dict[str, str]) -> None:
        element = Element(tag, attrs, parser.CurrentLineNumber, parser.CurrentColumnNumber + 1)
        (stack[-1].children if stack else roots).append(element)
        stack.append(element)

    parser.StartElementHandler = start
    parser.EndElementHandler = lambda tag: stack.pop()
    try:
        parser.Parse(data, True)
    except expat.ExpatError as err:
        raise error("not well-formed XML: {}".format(expat.ErrorString(err.code)),
                    path, err.lineno, err.offset + 1) from None
    return roots[0]


class AttributeReader:
    """Typed attribute access; a failure names the element's file, line and column."""

    def __init__(self, path: Optional[str], error: Type[FormatError]) -> None:
        self.path = path
        self.error_class = error

    def error(self, element: Element, message: str) -> FormatError:
        return self.error_class(message, self.path, element.line, element.column)

    def raw(self, el: Element, name: str) -> str:
        if name not in el.attrs:
            raise self.error(el, "<{}> lacks the attribute {}=\"...\"".format(el.tag, name))
        return el.attrs[name].strip()

    def number(self, el: Element, name: str, check: Callable[[float], bool] = math.isfinite,
               expected: str = "a number") -> float:
        text = self.raw(el, name)
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not (math.isfinite(value) and check(value)):
            raise self.error(el, "<{}> {}=\"{}\": expected {}".format(el.tag, name, text, expected))
        return value

    def integer(self, el: Element, name: str) -> int:
        text = self.raw(el, name)
        if not _INT.match(text):
            raise self.error(el, "<{}> {}=\"{}\": expected an integer".format(el.tag, name, text))
        return int(text)

    def flag(self, el: Element, name: str) -> bool:
        text = self.raw(el, name).lower()
        if text not in ("true", "false", "1", "0"):
            raise self.error(el, "<{}> {}=\"{}\": expected true or false".format(
                el.tag, name, text))
        return text in ("true", "1")


def read_bytes(path: Union[str, Path], error: Type[FormatError] = FormatError) -> bytes:
    try:
        return Path(path).read_bytes()
    except OSError as err:
        raise error("cannot read: {}".format(err.strerror), str(path)) from err
