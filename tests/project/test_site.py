"""The documentation site builds with ``mkdocs build --strict`` (docs/mkdocs.yml): every
relative link and anchor on it resolves, every page is in its navigation, and it holds the
pages it is for.

Evidence: MkDocs itself, run as a reader would run it; --strict turns its warnings (a link
to a file or heading that is not on the site, a page missing from the navigation,
validation set in docs/mkdocs.yml) into a failed build.
"""

from __future__ import annotations

import os
import subprocess
import sys

from support import ROOT

CONFIG = ROOT / "docs" / "mkdocs.yml"


def test_site_builds_strict_with_every_kind_of_page(tmp_path):
    site = tmp_path / "site"
    env = {k: v for k, v in os.environ.items() if k != "CODERMIND_EXECUTE_NOTEBOOKS"}
    env["NO_MKDOCS_2_WARNING"] = "1"        # mkdocs-material's banner about MkDocs 2.0
    r = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-q",
                        "-f", str(CONFIG), "-d", str(site)],
                       cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stdout + r.stderr
    pages = ["index.html",                                       # README.md
             "docs/index.html", "docs/command-line/index.html",
             "docs/reference/index.html", "docs/reference/shape-blob/index.html",
             "docs/results/index.html", "docs/results/compare/index.html",
             "benchmarks/index.html"]
    pages += [f"docs/notebooks/{p.stem}/index.html"
              for p in sorted((ROOT / "docs" / "notebooks").glob("*.ipynb"))]
    missing = [p for p in pages if not (site / p).is_file()]
    assert missing == []
    # a notebook is rendered as a page (its code in it), not copied as a file
    page1 = (site / "docs" / "notebooks" / "page1" / "index.html").read_text(encoding="utf-8")
    assert "tutorialortho" in page1 and "mi.load_dict" in page1
    # the theme and the search index (the hook keeps the theme's files)
    assert list((site / "assets" / "stylesheets").glob("*.css"))
    assert (site / "search" / "search_index.json").is_file()
    # what pages link to is on the site: a plugin's source, the figures
    assert (site / "plugins" / "codermind" / "shapes" / "blob.py").is_file()
    assert (site / "docs" / "figures" / "tone_curve.png").is_file()
    # nothing is written into the checkout (mkdocs-jupyter's cache is off)
    assert not (tmp_path / ".cache").exists()


def test_readme_says_how_to_build_and_serve_the_site():
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    assert "mkdocs serve -f docs/mkdocs.yml" in readme
    assert "\ndocs = [" in (ROOT / "pyproject.toml").read_text(encoding="utf-8")
