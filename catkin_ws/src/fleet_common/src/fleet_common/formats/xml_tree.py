"""XML elements that know their line: a small tree built with expat.

`xml.etree` forgets where elements were; every FleetControl error names a
line, so `parse_xml` records expat's line and column for each start tag, and
`AttributeReader` turns attributes into numbers with errors that point there.
Within the limits of `fleet_common.limits`: a file of at most MAX_XML_BYTES
(its size is checked before it is read), elements nested at most
MAX_XML_DEPTH deep (the tree is walked without recursion anyway), integers of
at most MAX_INT_DIGITS digits, and values quoted as short excerpts. Entity
expansion bombs are refused by expat itself (2.4 and later).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Dict, List, Optional, Type, Union
from xml.parsers import expat

from ..errors import FleetError, FormatError
from ..limits import (EXCERPT_CHARS, MAX_INT_DIGITS, MAX_XML_BYTES, MAX_XML_DEPTH, DecodeError,
                      one_line, parse_int)
from .lines import read_bytes



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
        out: List[Element] = []
        todo = [self]
        while todo:
            element = todo.pop()
            out.append(element)
            todo.extend(reversed(element.children))
        return out


def parse_xml(data: Union[str, bytes], path: Optional[str] = None,
              error: Type[FormatError] = FormatError) -> Element:
    """The document's root element; malformed XML raises `error` with line and column."""
    parser = expat.ParserCreate()
    stack: List[Element] = []
    roots: List[Element] = []

    def start(tag: str, attrs: Dict[str, str]) -> None:
        if len(stack) >= MAX_XML_DEPTH:
            raise error("elements nested deeper than {}".format(MAX_XML_DEPTH), path,
                        parser.CurrentLineNumber, parser.CurrentColumnNumber + 1)
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
    except UnicodeEncodeError:  # text given in code, with characters UTF-8 cannot hold
        raise error("not UTF-8 text", path, 1) from None
    except FleetError:
        raise  # ours, from a handler: it says where
    except (LookupError, ValueError, UnicodeError) as err:  # what the declared encoding makes expat do
        raise error("the encoding its XML declaration names cannot be read ({}); expected UTF-8 or a "
                    "one-byte encoding such as ISO-8859-1".format(one_line(str(err), EXCERPT_CHARS)),
                    path, 1) from None
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
            raise self.error(el, "<{}> lacks the attribute {}=\"...\"".format(
                one_line(el.tag, EXCERPT_CHARS), name))
        return el.attrs[name].strip()

    def number(self, el: Element, name: str, check: Callable[[float], bool] = math.isfinite,
               expected: str = "a number") -> float:
        text = self.raw(el, name)
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not (math.isfinite(value) and check(value)):
            raise self.error(el, "{}: expected {}".format(_shown(el, name, text), expected))
        return value

    def integer(self, el: Element, name: str) -> int:
        text = self.raw(el, name)
        try:
            return parse_int(text, MAX_INT_DIGITS)
        except DecodeError:
            raise self.error(el, "{}: expected an integer of at most {} digits".format(
                _shown(el, name, text), MAX_INT_DIGITS)) from None

    def flag(self, el: Element, name: str) -> bool:
        text = self.raw(el, name).lower()
        if text not in ("true", "false", "1", "0"):
            raise self.error(el, "{}: expected true or false".format(_shown(el, name, text)))
        return text in ("true", "1")


def _shown(el: Element, name: str, text: str) -> str:
    """`<tag> name="value"` for a message, the value cut short and escaped."""
    return "<{}> {}=\"{}\"".format(one_line(el.tag, EXCERPT_CHARS), name,
                                   one_line(text, EXCERPT_CHARS))


def read_xml_bytes(path: Union[str, Path], error: Type[FormatError] = FormatError) -> bytes:
    """A file's bytes (expat reads the encoding its declaration names), at most MAX_XML_BYTES."""
    return read_bytes(str(path), error, MAX_XML_BYTES)
