"""A tiny XML/SVG text builder: elements as nested tuples rendered with proper escaping.

The exporters only write; pulling lxml in for that would slow ``mse export`` start-up and
make attribute order depend on a library version, so output is plain, stable text.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from xml.sax.saxutils import escape as _escape
from xml.sax.saxutils import quoteattr as _quoteattr

from mse.limits import xml_safe

Attributes = Mapping[str, str | float | int | None]


def escape(text: str) -> str:
    """Character data; characters XML cannot hold (controls, lone surrogates) become U+FFFD."""
    return _escape(xml_safe(text))


def quoteattr(text: str) -> str:
    return _quoteattr(xml_safe(text))


@dataclass(frozen=True)
class Element:
    """An element; ``children`` holds elements, :class:`Comment` or text strings."""

    tag: str
    attributes: Attributes = field(default_factory=dict)
    children: tuple[Element | Comment | str, ...] = ()
    #: Mixed content written on one line as given (speech text with marks: no white space added).
    inline: bool = False


@dataclass(frozen=True)
class Comment:
    text: str


def element(tag: str, attributes: Attributes | None = None, *children: Element | Comment | str) -> Element:
    return Element(tag, attributes or {}, tuple(children))


def attribute_text(attributes: Attributes) -> str:
    """`` a="1" b="x"`` (None values are left out, floats keep their repr)."""
    parts = []
    for name, value in attributes.items():
        if value is None:
            continue
        parts.append(f" {name}={quoteattr(str(value))}")
    return "".join(parts)


def render(node: Element | Comment | str, indent: str = "  ", depth: int = 0) -> str:
    """Pretty text for ``node``; elements holding text stay on one line."""
    pad = indent * depth
    if isinstance(node, str):
        return pad + escape(node)
    if isinstance(node, Comment):
        return f"{pad}<!-- {xml_safe(node.text).replace('--', '- -')} -->"
    opening = f"{pad}<{node.tag}{attribute_text(node.attributes)}"
    if not node.children:
        return opening + "/>"
    if node.inline:
        return opening + ">" + "".join(render(child, "", 0) for child in node.children) + f"</{node.tag}>"
    if all(isinstance(child, str) for child in node.children):
        text = "".join(escape(child) for child in node.children if isinstance(child, str))
        return f"{opening}>{text}</{node.tag}>"
    inner = "\n".join(render(child, indent, depth + 1) for child in node.children)
    return f"{opening}>\n{inner}\n{pad}</{node.tag}>"


def document(root: Element, *, declaration: bool = True, leading: Iterable[Comment] = ()) -> str:
    head = '<?xml version="1.0" encoding="UTF-8"?>\n' if declaration else ""
    comments = "".join(render(comment) + "\n" for comment in leading)
    return head + comments + render(root) + "\n"
