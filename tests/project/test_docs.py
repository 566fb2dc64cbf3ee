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


# --- results pages and the benchmarks that write them ---------------------------------------

RESULTS = ROOT / "docs" / "results"
BENCHMARKS = ROOT / "benchmarks"
_SECTION = re.compile(r"<!-- begin (\S+) (\S+) -->\n(.*?)<!-- end \1 \2 -->", re.S)
_DATE = re.compile(r"^Date: \d{4}-\d{2}-\d{2}; machine: \S.*$", re.M)


def results_pages() -> list[Path]:
    return sorted(p for p in RESULTS.glob("*.md") if p.name != "README.md")


def section_problems(page: Path, benchmarks: Path = BENCHMARKS) -> list[str]:
    """What is wrong with a results page's generated sections: none, a section whose script
    is missing or does not write this page (``--write-results`` and the page's name in its
    source, the section's name too), or one that does not open with the command (that
    script with ``--write-results``) and a date-and-machine line."""
    text = page.read_text(encoding="utf-8")
    sections = _SECTION.findall(text)
    if not sections:
        return [f"{page.name}: no generated section"]
    bad = []
    for script, name, body in sections:
        where = f"{page.name} [{script} {name}]"
        source = benchmarks / script
        if not source.is_file():
            bad.append(f"{where}: no benchmarks/{script}")
            continue
        code = source.read_text(encoding="utf-8")
        if "--write-results" not in code and "_results.add_argument" not in code:
            bad.append(f"{where}: {script} has no --write-results")
        if page.name not in code:
            bad.append(f"{where}: {script} does not name {page.name}")
        base = re.sub(r"-[a-z]\d+$", "", name)
        if name != "results" and f'"{base}' not in code:
            bad.append(f"{where}: {script} writes no section {name!r}")
        lines = body.strip().splitlines()
        command = re.fullmatch(rf"Command: `python benchmarks/{re.escape(script)}( [^`]*)?`",
                               lines[0] if lines else "")
        if not command or "--write-results" not in lines[0]:
            bad.append(f"{where}: the first line is not its command with --write-results")
        if not _DATE.search(body):
            bad.append(f"{where}: no 'Date: YYYY-MM-DD; machine: ...' line")
    return bad


@pytest.mark.parametrize("page", results_pages(), ids=lambda p: p.name)
def test_results_page_is_written_by_a_benchmark(page):
    assert section_problems(page) == []


def test_section_check_catches_missing_scripts_commands_and_dates(tmp_path):
    bench = tmp_path / "benchmarks"
    bench.mkdir()
    (bench / "good.py").write_text('PAGE = "p.md"  # --write-results; section "extra"\n')
    (bench / "other.py").write_text("# writes nothing\n")
    page = tmp_path / "p.md"
    page.write_text("# P\n\nText.\n")
    assert section_problems(page, bench) == ["p.md: no generated section"]
    ok = ("Command: `python benchmarks/good.py --write-results`\n\n"
          "Date: 2026-01-02; machine: some CPU, 2 cores; commit abc\n\n| a |\n| --- |\n")
    page.write_text("# P\n\n<!-- begin good.py results -->\n" + ok + "<!-- end good.py results -->\n"
                    "<!-- begin good.py extra -->\n" + ok + "<!-- end good.py extra -->\n")
    assert section_problems(page, bench) == []
    page.write_text("<!-- begin gone.py results -->\n" + ok + "<!-- end gone.py results -->\n"
                    "<!-- begin other.py results -->\n" + ok.replace("good", "other")
                    + "<!-- end other.py results -->\n"
                    "<!-- begin good.py nothing -->\nCommand: `python benchmarks/good.py`\n"
                    "Date: yesterday\n<!-- end good.py nothing -->\n")
    assert section_problems(page, bench) == [
        "p.md [gone.py results]: no benchmarks/gone.py",
        "p.md [other.py results]: other.py has no --write-results",
        "p.md [other.py results]: other.py does not name p.md",
        "p.md [good.py nothing]: good.py writes no section 'nothing'",
        "p.md [good.py nothing]: the first line is not its command with --write-results",
        "p.md [good.py nothing]: no 'Date: YYYY-MM-DD; machine: ...' line"]


def test_results_index_and_readme_link_every_page():
    index = (RESULTS / "README.md").read_text(encoding="utf-8")
    readme = README.read_text(encoding="utf-8")
    for page in results_pages():
        assert f"]({page.name})" in index, f"docs/results/README.md does not index {page.name}"
        assert f"](docs/results/{page.name})" in readme, f"README.md does not quote {page.name}"
    for script in re.findall(r"python benchmarks/(\w+\.py)", index):
        assert (BENCHMARKS / script).is_file(), script


def benchmark_scripts() -> list[Path]:
    return sorted(p for p in BENCHMARKS.glob("*.py") if not p.name.startswith("_"))


@pytest.mark.parametrize("script", benchmark_scripts(), ids=lambda p: p.name)
def test_benchmark_has_main_argparse_and_a_page(script):
    code = script.read_text(encoding="utf-8")
    assert "def main(" in code and "argparse" in code and 'if __name__ == "__main__":' in code
    assert "sys.path" not in code, "the package is installed editable: no sys.path edits"
    pages = [p.name for p in results_pages()
             if f"<!-- begin {script.name} " in p.read_text(encoding="utf-8")]
    assert pages, f"{script.name} feeds no page of docs/results/ (remove it, or give it one)"
    listed = (BENCHMARKS / "README.md").read_text(encoding="utf-8")
    assert f"`{script.name}`" in listed, f"benchmarks/README.md does not list {script.name}"


def _results_module():
    spec = importlib.util.spec_from_file_location("_results", BENCHMARKS / "_results.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_results_writer_replaces_only_its_section(tmp_path):
    r = _results_module()
    page = tmp_path / "page.md"
    page.write_text("# Page\n\nIntro, kept.\n")
    r.write(page, "| a |\n| --- |\n| 1 |\n", script="x.py", section="s", cmd="python benchmarks/x.py --write-results", seconds=3)
    r.write(page, "other\n", script="y.py", cmd="python benchmarks/y.py --write-results", seconds=3)
    r.write(page, "| a |\n| --- |\n| 2 |\n", script="x.py", section="s", cmd="python benchmarks/x.py --write-results", seconds=3)
    text = page.read_text()
    assert text.startswith("# Page\n\nIntro, kept.\n\n<!-- begin x.py s -->\nCommand: "
                           "`python benchmarks/x.py --write-results`\n\nDate: ")
    assert "| 2 |" in text and "| 1 |" not in text and text.count("<!-- begin") == 2
    assert _DATE.search(text) and "<!-- end y.py results -->" in text
    assert r.command([str(BENCHMARKS / "x.py"), "--runs", "3", "--write-results", "/tmp/q.md"]) \
        == "python benchmarks/x.py --runs 3 --write-results"
