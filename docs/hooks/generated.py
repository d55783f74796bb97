"""MkDocs hook: pages generated from the code at build time.

``docs/reference/cli.md`` and ``docs/reference/components.md`` hold only a marker comment; this hook replaces it with
the command-line reference written from ``pkmstiff.cli.build_parser()`` and the component catalogue written from the
component registry, so that the documentation cannot drift from the code.  The same functions are used by
``tests/test_docs.py``.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
CLI_MARKER = "<!-- generated: cli-reference -->"
CATALOGUE_MARKER = "<!-- generated: component-catalogue -->"
_HELP_WIDTH = "100"  # fixed terminal width, so the generated text does not depend on the building machine


def _import_path() -> None:
    if str(ROOT) not in sys.path:  # the worktree's package, also when pkmstiff is not installed
        sys.path.insert(0, str(ROOT))


def _subcommands(parser: argparse.ArgumentParser) -> list[tuple[str, str, argparse.ArgumentParser]]:
    """(name, one-line help, parser) of every sub-command of ``parser``, in declaration order."""
    out = []
    for action in parser._actions:  # argparse has no public accessor for sub-parsers
        if isinstance(action, argparse._SubParsersAction):
            helps = {a.dest: a.help or "" for a in action._choices_actions}
            out.extend((name, helps.get(name, ""), sub) for name, sub in action.choices.items())
    return out


def cli_markdown() -> str:
    """Markdown for every sub-command and sub-sub-command of ``pkmstiff``: usage, description and options."""
    _import_path()
    from pkmstiff.cli import build_parser

    old = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = _HELP_WIDTH
    try:
        parser = build_parser()
        lines = ["## `pkmstiff`", "", "```text", parser.format_help().rstrip(), "```", ""]

        def walk(p: argparse.ArgumentParser, prefix: str, depth: int) -> None:
            for name, help_text, sub in _subcommands(p):
                title = f"{prefix} {name}"
                lines.extend([f"{'#' * min(depth, 6)} `{title}`", ""])
                if help_text:
                    lines.extend([help_text[:1].upper() + help_text[1:] + ".", ""])
                lines.extend(["```text", sub.format_help().rstrip(), "```", ""])
                walk(sub, title, depth + 1)

        walk(parser, "pkmstiff", 3)
    finally:
        if old is None:
            os.environ.pop("COLUMNS", None)
        else:
            os.environ["COLUMNS"] = old
    return "\n".join(lines)


def catalogue_markdown() -> str:
    """The component catalogue from the models' parameter declarations (``components.catalogue.markdown()``),
    without its title line: the page supplies the title and the introduction."""
    _import_path()
    from components.catalogue import markdown

    text = markdown()
    return text.split("\n", 1)[1].lstrip("\n") if text.startswith("# ") else text


def on_page_markdown(markdown: str, page, config, files) -> str:  # noqa: ARG001 (MkDocs hook signature)
    if CLI_MARKER in markdown:
        markdown = markdown.replace(CLI_MARKER, cli_markdown())
    if CATALOGUE_MARKER in markdown:
        markdown = markdown.replace(CATALOGUE_MARKER, catalogue_markdown())
    return markdown
