"""The index page of a run: every figure and file the run wrote, each with a sentence on what it shows.

A report is a list of :class:`Entry` grouped in sections; :func:`write_index` writes it as Markdown
(``index.md``, readable on any code host) and HTML (``index.html``, figures inline, for a browser).
"""
from __future__ import annotations

import html
import os
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
    return Path(os.path.relpath(path, root)).as_posix()


def write_index(out_dir, title: str, intro: str, sections: list[Section]) -> tuple[Path, Path]:
    """Write ``index.md`` and ``index.html`` into out_dir; returns both paths.

    Raises FileNotFoundError if an entry names a file that does not exist: an index never links to
    nothing.
    """
    out_dir = Path(out_dir)
    missing = [str(e.path) for s in sections for e in s.entries if not Path(e.path).exists()]
    if missing:
        raise FileNotFoundError(f"the index would name files that were not written: {', '.join(missing)}")
    md = [f"# {title}", "", intro, ""]
    body = [f"<h1>{html.escape(title)}</h1>", f"<p>{html.escape(intro)}</p>"]
    for section in sections:
        md += [f"## {section.title}", ""]
        body.append(f"<h2>{html.escape(section.title)}</h2>")
        if section.summary:
            md += ["```text", section.summary, "```", ""]
            body.append(f"<pre>{html.escape(section.summary)}</pre>")
        for entry in section.entries:
            link = _relative(entry.path, out_dir)
            if entry.path.suffix.lower() == ".png":
                md += [f"### {entry.title}", "", entry.sentence, "", f"![{entry.title}]({link})", ""]
                body.append(f"<h3>{html.escape(entry.title)}</h3><p>{html.escape(entry.sentence)}</p>"
                            f'<img src="{html.escape(link)}" alt="{html.escape(entry.title)}" style="max-width:100%">')
            else:
                md += [f"- [{entry.title}]({link}): {entry.sentence}", ""]
                body.append(f'<p><a href="{html.escape(link)}">{html.escape(entry.title)}</a>: '
                            f"{html.escape(entry.sentence)}</p>")
        md.append("")
    md_path, html_path = out_dir / "index.md", out_dir / "index.html"
    md_path.write_text("\n".join(md), encoding="utf-8")
    html_path.write_text("<!doctype html><html><head><meta charset='utf-8'><title>" + html.escape(title)
                         + "</title></head><body style='font-family:sans-serif;max-width:60em;margin:auto'>"
                         + "\n".join(body) + "</body></html>\n", encoding="utf-8")
    return md_path, html_path
