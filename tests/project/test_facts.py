"""Citations of docs/facts.md resolve, and nothing sends a reader to a document outside the
repository.

Evidence: the numbered headings of docs/facts.md against every ``facts.md F<n>[.<m>]`` in
this checkout's code, tests, benchmarks, scenes and docs; and a scan of the same files for
citations of the tutorial specification (``spec 2.x``, ``TUTORIAL_SPEC``), which is not in
the repository.
"""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
FACTS = ROOT / "docs" / "facts.md"
OWN = Path(__file__).resolve().relative_to(ROOT).as_posix()
SUFFIXES = {".py", ".md", ".xml", ".txt", ".json", ".toml", ".cfg", ".rst", ".sh", ".ipynb"}
SKIP_DIRS = {".git", ".venv", "venv", "__pycache__", ".pytest_cache", ".hypothesis", "build",
             "dist", "node_modules"}

#: Files that may still cite the specification, until their rewrite lands (entries ending in
#: "/" are folders). docs/reference/integrator-tutorialpath.md is generated from
#: tutorialpath.py's docstring; docs/figures/stability.* are written by the harness's sweeps.
SPEC_CITATIONS_ALLOWED: set[str] = set()

REF = r"F\d+(?:\.\d+)?"
CITATION = re.compile(rf"facts\.md\s+({REF}(?:(?:\s*,\s*|\s+and\s+|-){REF})*)")
LOOKS_LIKE_CITATION = re.compile(r"facts\.md\s+(?:§|\d|F(?!<))")
SPEC_CITATION = re.compile(r"TUTORIAL_SPEC|\b[Ss]pec\s+(?:section\s+)?§?\s*\d")


def sections() -> set[str]:
    return set(re.findall(rf"^#{{2,3}} ({REF})[. ]", FACTS.read_text(), re.M))


def files():
    """Every text file of the checkout that could cite something, as (relative path, text)."""
    for path in sorted(ROOT.rglob("*")):
        rel = path.relative_to(ROOT)
        if (path.is_file() and path.suffix in SUFFIXES
                and not SKIP_DIRS.intersection(rel.parts)
                and not any(p.endswith(".egg-info") for p in rel.parts)):
            yield rel.as_posix(), path.read_text(errors="replace")


def allowed(rel: str) -> bool:
    return any(rel == a or (a.endswith("/") and rel.startswith(a)) for a in SPEC_CITATIONS_ALLOWED)


def line(text: str, pos: int) -> int:
    return text.count("\n", 0, pos) + 1


def cited(text: str):
    """(position, section) for every section a text cites."""
    for m in CITATION.finditer(text):
        for ref in re.findall(REF, m.group(1)):
            yield m.start(), ref


def test_facts_sections_are_numbered_once_under_their_parent():
    heads = re.findall(rf"^(#{{2,3}}) ({REF})[. ]", FACTS.read_text(), re.M)
    numbers = [n for _, n in heads]
    assert len(numbers) == len(set(numbers)) > 10
    for level, n in heads:
        assert (level == "##") == ("." not in n), n
        if "." in n:
            assert n.split(".")[0] in numbers, n


def test_every_cited_section_exists():
    known = sections()
    bad = [f"{rel}:{line(text, pos)}: {ref}"
           for rel, text in files() for pos, ref in cited(text) if ref not in known]
    assert bad == []


def test_citations_of_the_facts_have_the_one_form():
    """`facts.md F6.3`, `facts.md F7, F8`, `facts.md F7-F10`: no `facts.md §6`, `facts.md 6.3`."""
    bad = [f"{rel}:{line(text, m.start())}: {text[m.start():m.end() + 8]!r}"
           for rel, text in files() if rel != OWN for m in LOOKS_LIKE_CITATION.finditer(text)
           if not CITATION.match(text, m.start())]
    assert bad == []


def test_the_repository_cites_the_facts():
    """Code, tests and docs cite the facts (guards against a scan that finds nothing)."""
    citing = {rel.split("/")[0] for rel, text in files() if any(cited(text))}
    assert {"plugins", "reference", "tests", "docs", "scenes"} <= citing


def test_nothing_cites_the_tutorial_spec():
    bad = [f"{rel}:{line(text, m.start())}: {m.group(0)!r}"
           for rel, text in files() if rel != OWN and not allowed(rel)
           for m in SPEC_CITATION.finditer(text)]
    assert bad == []


def test_every_allowance_is_still_needed():
    """An entry of SPEC_CITATIONS_ALLOWED whose files no longer cite the spec goes."""
    citing = {rel for rel, text in files() if SPEC_CITATION.search(text)}
    stale = [a for a in SPEC_CITATIONS_ALLOWED
             if not any(rel == a or (a.endswith("/") and rel.startswith(a)) for rel in citing)]
    assert stale == []
