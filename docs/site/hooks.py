"""MkDocs hook: the site is the repository's own documentation, in the repository's layout.

The pages link as they do on GitHub: the README to ``docs/...``, the docs to the plugins'
sources (``../plugins/...``), to tests and to ``benchmarks/README.md``. So the site's files
are taken from the repository root with their repository paths (``README.md`` is the home
page, ``docs/tutorial.md`` becomes ``docs/tutorial/``), and every relative link that
resolves in the repository resolves on the site; ``mkdocs build --strict`` fails on one
that does not. Markdown and notebooks become pages; sources, figures and scene files are
copied as they are, so a link to a plugin's source shows its code.

MkDocs walks its ``docs_dir`` (``docs/site/``, this folder) and this hook replaces what it
found (but not the theme's files) with the files below: pointing ``docs_dir`` at the repository root would walk the
virtual environment too, and MkDocs refuses ``docs/`` itself, the folder of
``mkdocs.yml``.
"""

from __future__ import annotations

from pathlib import Path

from mkdocs.plugins import event_priority
from mkdocs.structure.files import File, Files

ROOT = Path(__file__).resolve().parents[2]

#: Rendered as pages.
PAGES = ("README.md", "docs/**/*.md", "docs/**/*.ipynb", "benchmarks/README.md")
#: Copied as they are (what the pages link to or show).
ASSETS = ("docs/**/*.png", "docs/**/*.py", "docs/**/*.json", "docs/**/*.csv",
          "scenes/**/*.png", "scenes/**/*.xml", "scenes/**/*.txt", "scenes/**/*.py",
          "plugins/**/*.py", "reference/**/*.py", "tests/**/*.py", "benchmarks/*.py")
#: Not part of the site: caches.
SKIP = ("__pycache__/", ".ipynb_checkpoints/")


def repository_files() -> list[str]:
    """Repository paths (POSIX, relative to the root) of every file the site holds."""
    found: set[str] = set()
    for pattern in PAGES + ASSETS:
        for path in ROOT.glob(pattern):
            rel = path.relative_to(ROOT).as_posix()
            if path.is_file() and not any(s in rel + "/" for s in SKIP):
                found.add(rel)
    return sorted(found)


@event_priority(100)      # before mkdocs-jupyter's on_files, which turns notebooks into pages
def on_files(files: Files, config) -> Files:
    """The theme's files (CSS, JavaScript, fonts) and the repository's; what MkDocs found in
    ``docs_dir`` is dropped."""
    docs_dir = Path(config["docs_dir"]).resolve()
    theme = [f for f in files if not Path(f.abs_src_path).resolve().is_relative_to(docs_dir)]
    return Files(theme + [File(rel, str(ROOT), config["site_dir"], config["use_directory_urls"])
                          for rel in repository_files()])
