"""Checks every rendered report passes (issue 28, item 2): valid HTML5, no raw Markdown in the HTML, no absolute
paths, every assumption printed once."""

from __future__ import annotations

import re

#: Markdown that a renderer leaked into HTML text: list bullets or headings at a line start, bold, images, links
_MARKDOWN = [re.compile(p, re.MULTILINE) for p in (r"^\s*[-*] \S", r"^\s*#{1,6} ", r"\*\*\S", r"!\[", r"\]\(")]
#: an absolute POSIX path of this machine (site-packages, /tmp, /home, /work, /usr, /root) or a Windows drive path
_ABSOLUTE = re.compile(r"(?<![\w.~])(/(?:tmp|home|work|usr|root|opt|var)/|site-packages|[A-Z]:\\\\)")


def text_nodes(html_text: str) -> list[str]:
    """The HTML parsed strictly as HTML5 (html5lib raises on any parse error); the text of every element except
    style/script."""
    import html5lib

    doc = html5lib.HTMLParser(strict=True, namespaceHTMLElements=False).parse(html_text)
    out = []
    for el in doc.iter():
        if el.tag in ("style", "script"):
            continue
        for t in (el.text, el.tail):
            if t and t.strip():
                out.append(t)
    return out


def check_report(html_text: str, md_text: str) -> None:
    texts = text_nodes(html_text)
    for t in texts:
        for pat in _MARKDOWN:
            assert not pat.search(t), f"raw Markdown in the HTML: {t[:120]!r}"
    for name, text in (("HTML", "\n".join(texts)), ("Markdown", md_text)):
        m = _ABSOLUTE.search(text)
        assert m is None, f"absolute path in the {name}: {text[max(0, m.start() - 60):m.end() + 60]!r}"
    # every assumption once: the first cells of the assumption tables are unique
    section = md_text.split("## Assumptions", 1)[1].split("\n## ", 1)[0]
    keys = [line.split("|")[1].strip() for line in section.splitlines()
            if line.startswith("| ") and not line.startswith("| Assumption")]
    assert len(keys) == len(set(keys)), f"repeated assumptions: {sorted(k for k in keys if keys.count(k) > 1)}"
