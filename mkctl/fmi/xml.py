"""Writing an FMU's XML (modelDescription.xml, buildDescription.xml) so that every text in it, a user's effect
description or unit included, comes back exactly as written when the file is parsed.

ElementTree escapes ``& < > "`` and, in attributes, line breaks and tabs (``&#10;``, ``&#9;``); minidom's pretty
printer, used before, wrote them back raw, and a parser then turns them into spaces. :func:`xml_bytes` indents
with ElementTree itself. Characters XML 1.0 cannot carry at all (control characters other than tab and line
breaks, lone surrogates, U+FFFE, U+FFFF) have no escape: :func:`check_xml_texts` refuses them in one line.
"""
from __future__ import annotations

import copy
import re
from xml.etree import ElementTree as ET

from ..errors import MkctlError

#: Characters outside XML 1.0's Char production (https://www.w3.org/TR/xml/#charsets).
_FORBIDDEN = re.compile("[^\t\n\r\u0020-\ud7ff\ue000-\ufffd\U00010000-\U0010ffff]")


class XmlTextError(MkctlError, ValueError):
    """A text that an XML file cannot carry."""


def xml_forbidden(text: str) -> int | None:
    """The index of the first character of ``text`` that XML 1.0 cannot carry, or None."""
    match = _FORBIDDEN.search(text)
    return None if match is None else match.start()


def check_xml_texts(root: ET.Element, where: str = "modelDescription.xml") -> None:
    """Raise :class:`XmlTextError` naming the element, the attribute and the character when any text or attribute
    value under ``root`` has a character XML cannot carry."""
    for element in root.iter():
        texts = [("text", element.text), ("tail", element.tail), *element.attrib.items()]
        for key, value in texts:
            if value is not None and (bad := xml_forbidden(value)) is not None:
                raise XmlTextError(f"{where}: <{element.tag}> {key} {value!r} has a character XML cannot carry "
                                   f"({value[bad]!r})")


def xml_bytes(root: ET.Element, indent: str = "\t") -> bytes:
    """UTF-8 bytes of the XML document ``root`` (declaration, indented), every text escaped by ElementTree and
    intact when parsed back. Raises :class:`XmlTextError` for a character XML cannot carry."""
    check_xml_texts(root)
    tree = copy.deepcopy(root)
    ET.indent(tree, space=indent)
    return ET.tostring(tree, encoding="UTF-8", xml_declaration=True) + b"\n"
