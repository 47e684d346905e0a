"""The index page of a run: every figure and file the run wrote, each with a sentence on what it shows.

A report is a list of :class:`Entry` grouped in sections; :func:`write_index` writes it as Markdown
(``index.md``, readable on any code host) and HTML (``index.html``, figures inline, for a browser).

Titles, sentences and file names may carry a user's text (a record's name): in HTML every text is escaped
(:func:`html.escape`) and every link percent-encoded; in Markdown every text is made inert
(:func:`markdown_text`: its punctuation backslash-escaped, line breaks joined), links are percent-encoded and a
summary's code fence is longer than any run of backticks in it. Characters that are not printable (control
characters, the lone surrogates of an undecodable file name) are written as their escapes (:func:`visible`).
"""
from __future__ import annotations

import html
import os
import re
from urllib.parse import quote
from dataclasses import dataclass, field
from pathlib import Path


@dataclass
class Entry:
    """One file of the run: its path, a title, and a sentence on what it shows."""

    path: Path
    title: str
    sentence: str


@dataclass
class Section:
    """A step of the run, with the files it wrote and an optional summary paragraph."""

    title: str
    summary: str = ""
    entries: list[Entry] = field(default_factory=list)

    def add(self, path, title: str, sentence: str) -> None:
        self.entries.append(Entry(Path(path), title, sentence))


def _relative(path: Path, root: Path) -> str:
    """The link from root to path, percent-encoded (a space, '(', '%', '#', '"' or a non-ASCII letter of a file's
    name cannot end or change it)."""
    text = Path(os.path.relpath(path, root)).as_posix()
    return quote(text.encode("utf-8", "surrogateescape"), safe="/")


def visible(text: str, keep: str = "") -> str:
    """text with every character that is not printable (other than those in ``keep``) written as its Python
    escape (``\\x01``, ``\\udcff``): no control character or lone surrogate reaches a page."""
    return "".join(c if c.isprintable() or c in keep else c.encode("unicode_escape").decode("ascii") for c in text)


#: Characters that start or change Markdown's inline markup (links, images, emphasis, code, HTML, entities,
#: tables, strike-through, math); CommonMark lets any ASCII punctuation be backslash-escaped.
_MARKDOWN_SPECIAL = re.compile(r"([\\`*_{}\[\]<>()#!|~&$])")
#: What would start a block at the beginning of a line: a list item, a quote, a heading underline, "1." or "1)".
_MARKDOWN_LEADING = re.compile(r"^(\s*)([-+=>:]|\d+[.)])")


def markdown_text(text: str) -> str:
    """text made inert in Markdown: on one line (line breaks joined with spaces), every character of inline markup
    backslash-escaped, and a leading list or quote marker too (no link, image, emphasis, HTML tag, entity, heading
    or list can come of it)."""
    escaped = _MARKDOWN_SPECIAL.sub(r"\\\1", visible(" ".join(str(text).splitlines())))
    return _MARKDOWN_LEADING.sub(lambda m: m.group(1) + m.group(2)[:-1] + "\\" + m.group(2)[-1], escaped)


def _fence(text: str) -> str:
    """A code fence longer than any run of backticks in text (so that text cannot close it)."""
    runs = [len(run) for run in re.findall("`+", text)]
    return "`" * max(3, max(runs, default=0) + 1)


def _html(text: str, keep: str = "") -> str:
    """text escaped for HTML (``& < > " '``), its unprintable characters as escapes (:func:`visible`)."""
    return html.escape(visible(str(text), keep=keep), quote=True)


def write_index(out_dir, title: str, intro: str, sections: list[Section]) -> tuple[Path, Path]:
    """Write ``index.md`` and ``index.html`` into out_dir; returns both paths.

    Raises FileNotFoundError if an entry names a file that does not exist: an index never links to
    nothing.
    """
    out_dir = Path(out_dir)
    missing = [str(e.path) for s in sections for e in s.entries if not Path(e.path).exists()]
    if missing:
        raise FileNotFoundError(f"the index would name files that were not written: {', '.join(missing)}")
    md = [f"# {markdown_text(title)}", "", markdown_text(intro), ""]
    body = [f"<h1>{_html(title)}</h1>", f"<p>{_html(intro)}</p>"]
    for section in sections:
        md += [f"## {markdown_text(section.title)}", ""]
        body.append(f"<h2>{_html(section.title)}</h2>")
        if section.summary:
            summary = visible(section.summary, keep="\n")
            fence = _fence(summary)
            md += [fence + "text", summary, fence, ""]
            body.append(f"<pre>{_html(section.summary, keep=chr(10))}</pre>")
        for entry in section.entries:
            link = _relative(entry.path, out_dir)
            title_md, sentence_md = markdown_text(entry.title), markdown_text(entry.sentence)
            if entry.path.suffix.lower() == ".png":
                md += [f"### {title_md}", "", sentence_md, "", f"![{title_md}]({link})", ""]
                body.append(f"<h3>{_html(entry.title)}</h3><p>{_html(entry.sentence)}</p>"
                            f'<img src="{html.escape(link)}" alt="{_html(entry.title)}" style="max-width:100%">')
            else:
                md += [f"- [{title_md}]({link}): {sentence_md}", ""]
                body.append(f'<p><a href="{html.escape(link)}">{_html(entry.title)}</a>: '
                            f"{_html(entry.sentence)}</p>")
        md.append("")
    md_path, html_path = out_dir / "index.md", out_dir / "index.html"
    md_path.write_text("\n".join(md), encoding="utf-8")
    html_path.write_text("<!doctype html><html><head><meta charset='utf-8'><title>" + _html(title)
                         + "</title></head><body style='font-family:sans-serif;max-width:60em;margin:auto'>"
                         + "\n".join(body) + "</body></html>\n", encoding="utf-8")
    return md_path, html_path
