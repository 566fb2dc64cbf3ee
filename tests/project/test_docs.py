"""The documentation stays true to the repository: the plugin reference is what the
docstrings give now, and every relative link in README.md and docs/ resolves.

Evidence: the reference is compared with a regeneration in memory (docs/generate_reference.py);
links are checked against the files and headings of this checkout.
"""

from __future__ import annotations

import importlib.util
import re
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
README = ROOT / "README.md"


def _generator():
    spec = importlib.util.spec_from_file_location("generate_reference", ROOT / "docs" / "generate_reference.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module          # its dataclasses look their module up there
    spec.loader.exec_module(module)
    return module


# --- the plugin reference ------------------------------------------------------------------

def test_plugin_reference_is_fresh():
    stale = _generator().stale(ROOT)
    assert stale == [], ("docs/reference/ is stale; run `python docs/generate_reference.py`: "
                         + ", ".join(stale))


def test_reference_has_a_page_per_registered_plugin():
    # Independent of the generator's discovery: every register_<kind>("name", ...) line.
    registered = set()
    for path in (ROOT / "plugins").rglob("*.py"):
        for kind, name in re.findall(r'^\w+\.register_(\w+)\(\s*"([^"]+)"', path.read_text(), re.M):
            registered.add(f"{kind}-{name}.md")
    pages = {p.name for p in (ROOT / "docs" / "reference").glob("*.md")} - {"README.md"}
    assert registered and pages == registered


PLUGIN_SOURCE = '''
    import mitsuba as mi

    class Thing(mi.SamplingIntegrator):
        r"""
        .. _integrator-thing:

        A thing (:monosp:`thing`)
        -------------------------

        .. pluginparameters::

         * - max_depth
           - |int|
           - Longest path, :math:`|d| \\le 10` (Default: 5)
           - |exposed|

        Body with ``code`` and :math:`x^2`.

        .. note:: Read
           this twice.

        .. math::

            a = b

        .. tabs::

            .. code-tab:: xml

                <integrator type="thing"/>
        """

    mi.register_integrator("thing", lambda props, cls=Thing: cls(props))
'''


def test_generator_finds_a_plugin_of_a_new_kind_anywhere_under_plugins(tmp_path):
    gen = _generator()
    module = tmp_path / "plugins" / "newpkg" / "deep" / "thing.py"
    module.parent.mkdir(parents=True)
    module.write_text(textwrap.dedent(PLUGIN_SOURCE))
    pages = gen.render_all(tmp_path)
    assert set(pages) == {"integrator-thing.md", "README.md"}
    page = pages["integrator-thing.md"]
    assert "# `thing` (integrator): A thing" in page
    assert r"| `max_depth` | integer | Longest path, $\|d\| \le 10$ (Default: 5) | exposed |" in page
    assert "Body with `code` and $x^2$." in page
    assert "> **Note:** Read\n> this twice." in page
    assert "```math\na = b\n```" in page
    assert '```xml\n<integrator type="thing"/>\n```' in page
    assert "(../../plugins/newpkg/deep/thing.py)" in pages["README.md"]


def test_generator_refuses_a_plugin_without_parameter_table(tmp_path):
    gen = _generator()
    module = tmp_path / "plugins" / "p" / "bare.py"
    module.parent.mkdir(parents=True)
    module.write_text('import mitsuba as mi\n\nclass Bare:\n    """Bare\n    ----\n\n    Text."""\n\n'
                      'mi.register_bsdf("bare", lambda props, cls=Bare: cls(props))\n')
    with pytest.raises(gen.ReferenceError, match=r"plugins/p/bare.py:3: bsdf 'bare'.*pluginparameters"):
        gen.render_all(tmp_path)


# --- links ---------------------------------------------------------------------------------

_FENCE = re.compile(r"^ {0,3}(```|~~~).*?^ {0,3}\1[ \t]*$", re.M | re.S)
_CODE = re.compile(r"(`+).+?\1", re.S)
_LINK = re.compile(r"!?\[(?:[^\[\]]|\[[^\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
_HTML = re.compile(r"""<(?:a|img)\b[^>]*?\b(?:href|src)\s*=\s*["']([^"']+)["']""", re.I)
_HEADING = re.compile(r"^ {0,3}#{1,6}\s+(.*?)\s*#*\s*$", re.M)
_ANCHOR = re.compile(r"""<a\b[^>]*?\b(?:id|name)\s*=\s*["']([^"']+)["']""", re.I)


def _slug(heading: str) -> str:
    """GitHub's heading anchor: link text kept, lower case, punctuation dropped, spaces to '-'."""
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", heading).strip().lower()
    return re.sub(r"[^\w\- ]", "", text).replace(" ", "-")


def anchors(path: Path) -> set[str]:
    text = _FENCE.sub("", path.read_text(encoding="utf-8"))
    found, counts = set(_ANCHOR.findall(text)), {}
    for heading in _HEADING.findall(text):
        slug = _slug(heading)
        n = counts.get(slug, 0)
        counts[slug] = n + 1
        found.add(slug if n == 0 else f"{slug}-{n}")
    return found


def broken_links(path: Path) -> list[str]:
    text = _CODE.sub("", _FENCE.sub("", path.read_text(encoding="utf-8")))
    bad = []
    for target in _LINK.findall(text) + _HTML.findall(text):
        if re.match(r"[a-z][a-z0-9+.-]*:", target, re.I):
            continue                                   # http:, https:, mailto: ...
        file_part, _, anchor = target.partition("#")
        dest = (path.parent / file_part).resolve() if file_part else path
        if not dest.exists():
            bad.append(f"{target} (no such file)")
        elif anchor and dest.is_file() and dest.suffix == ".md" and anchor not in anchors(dest):
            bad.append(f"{target} (no such heading)")
    return bad


def documents() -> list[Path]:
    return [README] + sorted((ROOT / "docs").rglob("*.md"))


@pytest.mark.parametrize("path", documents(), ids=lambda p: p.relative_to(ROOT).as_posix())
def test_relative_links_resolve(path):
    assert broken_links(path) == []


def test_link_check_catches_broken_files_and_anchors(tmp_path):
    (tmp_path / "other.md").write_text("# Some `Heading`, here\n\n## Twice\n\n## Twice\n")
    page = tmp_path / "page.md"
    page.write_text("[ok](other.md#some-heading-here) [ok2](other.md#twice-1) [self](#top)\n"
                    "# Top\n[gone](missing.md) [bad anchor](other.md#nothing) "
                    "![img](pic.png) `[code](ignored.md)` [web](https://example.org/x)\n")
    assert broken_links(page) == ["missing.md (no such file)", "other.md#nothing (no such heading)",
                                  "pic.png (no such file)"]


def test_readme_is_short():
    assert len(README.read_text(encoding="utf-8").splitlines()) <= 200
