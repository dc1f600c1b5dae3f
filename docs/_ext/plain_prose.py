"""A griffe extension (mkdocs.yml loads it) that shows warpdyn's plain-prose docstrings as they read in the source.

warpdyn's docstrings are prose, not Google or NumPy style, and they write units and shapes in brackets and
XML elements in angle brackets: `(6,) [linear; angular] [m/s^2, rad/s^2]`, `(MJCF <actuator>)`. Markdown
reads the first as a reference link (mkdocs-autorefs then fails the strict build on the unknown target
'm/s^2, rad/s^2') and the second as an HTML tag (the word disappears from the page). They also start lists
and indented blocks (formulas, shapes, examples) right under a line of prose, which Markdown would run into
that paragraph. This extension, for every docstring:

- escapes a bracket that follows a closing bracket, and a `<` that would open a tag, outside code;
- puts a blank line before a list that follows a line of prose, and before an indented block that follows a
  line of prose ending with a colon (Markdown then shows the block as written, in a code block).

Nothing in warpdyn/ changes; tests/test_docs.py checks these rules.
"""

from __future__ import annotations

import re

# A bracket that follows a closing bracket (with at most one space): the identifier half of [text][id].
_REFERENCE = re.compile(r"(\]\s?)\[")
# An angle bracket that opens a tag: <name ...>, </name>, <name/>.
_TAG = re.compile(r"<(?=[A-Za-z/!?])")
# Inline code spans (one or more backticks, matched with the same count).
_CODE_SPAN = re.compile(r"(`+)(.+?)\1", re.S)
# A Markdown list item: "- ", "* ", "+ " or "1. ".
_LIST_ITEM = re.compile(r"^(?:[-*+]|\d+\.) ")


def _escape_prose(text: str) -> str:
    """Escape reference-link brackets and tags in `text`, a run of prose without code spans."""
    return _TAG.sub("&lt;", _REFERENCE.sub(r"\1\\[", text))


def _escape_paragraph(paragraph: str) -> str:
    """Escape the prose of a paragraph, leaving its code spans as they are."""
    out, position = [], 0
    for span in _CODE_SPAN.finditer(paragraph):
        out.append(_escape_prose(paragraph[position : span.start()]))
        out.append(span.group(0))
        position = span.end()
    out.append(_escape_prose(paragraph[position:]))
    return "".join(out)


def _is_list_item(line: str) -> bool:
    return bool(_LIST_ITEM.match(line))


def separate_blocks(text: str) -> str:
    """`text` with a blank line before each list and each colon-introduced indented block that follows a
    line of prose (Python-Markdown needs it: without it both run into the paragraph above)."""
    lines = text.split("\n")
    out: list[str] = []
    for i, line in enumerate(lines):
        previous = lines[i - 1] if i else ""
        prose_before = previous.strip() and not previous.startswith(" ") and not _is_list_item(previous)
        if prose_before and line.strip():
            if _is_list_item(line) or (line.startswith("    ") and previous.rstrip().endswith(":")):
                out.append("")
        out.append(line)
    return "\n".join(out)


def escape_docstring(text: str) -> str:
    """The docstring `text` as Markdown that shows what it says (see the module docstring): blocks
    separated, prose escaped; indented code blocks (4 spaces after a blank line) and fenced blocks are kept
    as written."""
    lines = separate_blocks(text).split("\n")
    out: list[str] = []
    in_code = in_fence = False
    prose: list[str] = []

    def flush():
        if prose:
            out.extend(_escape_paragraph("\n".join(prose)).split("\n"))
            prose.clear()

    for i, line in enumerate(lines):
        if line.lstrip().startswith("```"):
            flush()
            in_fence = not in_fence
            out.append(line)
            continue
        if in_fence:
            out.append(line)
            continue
        blank_before = i == 0 or not lines[i - 1].strip()
        if line.startswith("    ") and line.strip() and (in_code or blank_before) and not prose:
            in_code = True
            out.append(line)
            continue
        if in_code and not line.strip():
            out.append(line)
            continue
        in_code = False
        if not line.strip():
            flush()
            out.append(line)
        else:
            prose.append(line)
    flush()
    return "\n".join(out)


try:
    import griffe
except ImportError:  # tests/test_docs.py imports this file for its functions, without the docs extra
    griffe = None

if griffe is not None:

    class PlainProse(griffe.Extension):
        """Show every loaded object's docstring as written (see the module docstring)."""

        def on_instance(self, *, obj: griffe.Object, **kwargs) -> None:
            if obj.docstring is not None:
                obj.docstring.value = escape_docstring(obj.docstring.value)
