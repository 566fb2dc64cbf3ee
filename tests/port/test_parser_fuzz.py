"""Fuzz test of the port's scene parser (``codermind_ref.parse_scene``): mutated scene files
(bit flips, deletions, duplications, random keys and values, whole sections, truncations,
extreme numbers, random bytes) of the original tutorial scenes and the repository's bundled
ones either parse, or raise ``SceneError`` whose message is ``file:line: message`` with a line
of the file, and never any other exception.

CI runs a few hundred derandomized files; ``HYPOTHESIS_PROFILE=long`` runs 100 000.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from hypothesis import event, given, strategies as st

import codermind_ref as ref
from codermind_ref.scene import FACES, _MATERIAL_KEYS, _OBJECT_KEYS, _SCENE_KEYS
from support import ROOT, TUTORIAL, examples

KEYS = sorted(set(_SCENE_KEYS[4]) | set(_MATERIAL_KEYS[4])
              | {k for keys in _OBJECT_KEYS.values() for k in keys}
              | {"NumberOfBlobs", "Unknown.Key", "Center3"})
SECTIONS = ["Scene", "Material0", "Material1", "Sphere0", "Sphere9", "Blob0", "Light0",
            "Light1", "Material-1", "Sphere01", "Nested"]
VALUES = ["0", "1", "-1", "3", "1.3", "1.0", "2", "1e308", "-1e308", "1e-320", "nan", "inf",
          "-inf", "0x1p3", "90.0f", "1,2,3", "1,2", "1,2,3,4", ",,", "true", "false", "conic",
          "alpup.tga", "../page1/scene.txt", "", "9999999999999999999999", "-0", "1e", "+",
          ".", "0.6", "256"]


def _sources() -> dict[str, bytes]:
    files = {}
    tutorial = TUTORIAL
    for path in sorted(tutorial.glob("*/*.txt")) + sorted((ROOT / "scenes").glob("**/*.txt")):
        files[str(path.relative_to(path.parents[1]))] = path.read_bytes()
    return files


SOURCES = _sources()


@pytest.fixture(scope="module")
def folder(tmp_path_factory) -> Path:
    """A folder with the cube-map faces of page 4 and of the bundled scenes (linked), where
    mutated scenes are written."""
    tmp = tmp_path_factory.mktemp("fuzz") / "scenes"
    tmp.mkdir()
    faces = TUTORIAL / "page4"
    for face in faces.glob("*.tga"):
        (tmp / face.name).symlink_to(face)
    (tmp / "sky").symlink_to(ROOT / "scenes" / "sky")
    (tmp.parent / "sky").symlink_to(ROOT / "scenes" / "sky")     # scenes/user/: ../sky
    return tmp


@st.composite
def mutated(draw) -> bytes:
    name = draw(st.sampled_from(sorted(SOURCES)), label="source")
    data = bytearray(SOURCES[name])
    for _ in range(draw(st.integers(1, 4))):
        kind = draw(st.sampled_from(["flip", "delete", "duplicate", "entry", "section",
                                     "truncate", "number", "bytes"]))
        at = draw(st.integers(0, len(data)))
        if kind == "flip" and data:
            data[min(at, len(data) - 1)] ^= 1 << draw(st.integers(0, 7))
        elif kind == "delete":
            del data[at:at + draw(st.integers(1, 200))]
        elif kind == "duplicate":
            piece = data[at:at + draw(st.integers(1, 400))]
            where = draw(st.integers(0, len(data)))
            data[where:where] = piece
        elif kind == "entry":
            key = draw(st.one_of(st.sampled_from(KEYS), st.text(max_size=8)))
            value = draw(st.one_of(st.sampled_from(VALUES), st.text(max_size=8)))
            line = data.find(b"\n", at)
            where = len(data) if line < 0 else line + 1
            data[where:where] = f"  {key} = {value};\n".encode("utf-8", "replace")
        elif kind == "section":
            body = "".join(f"{draw(st.sampled_from(KEYS))} = {draw(st.sampled_from(VALUES))}; "
                           for _ in range(draw(st.integers(0, 3))))
            text = f"{draw(st.sampled_from(SECTIONS))} {{ {body}}}\n"
            data[at:at] = text.encode()
        elif kind == "truncate":
            del data[at:]
        elif kind == "number":
            numbers = list(re.finditer(rb"-?\d+(\.\d+)?f?", bytes(data)))
            if numbers:
                m = numbers[draw(st.integers(0, len(numbers) - 1))]
                data[m.start():m.end()] = draw(st.sampled_from(VALUES)).encode()
        elif kind == "bytes":
            data[at:at] = draw(st.binary(max_size=12).map(
                lambda b: b + draw(st.sampled_from([b"", b"{", b"}", b";", b"=", b"//", b"\n"]))))
    return bytes(data)


def check_parse(path: Path, data: bytes) -> str:
    """Parse ``data`` written to ``path``: a Scene, or a SceneError naming a line of it."""
    path.write_bytes(data)
    try:
        scene = ref.parse_scene(path)
    except ref.SceneError as e:
        m = re.fullmatch(re.escape(str(path)) + r":(\d+): (.+)", str(e), re.S)
        assert m, f"not 'file:line: message': {e}"
        lines = data.count(b"\n") + 1
        assert 1 <= int(m[1]) <= lines and e.line == int(m[1]) and e.path == str(path), str(e)
        return "error"
    assert scene.page in (1, 2, 4) and scene.width >= 1 and scene.height >= 1
    for warning in scene.warnings:
        assert warning.startswith(f"{path}:"), warning
    return "parsed"


@examples(ci=300, long=100_000)
@given(data=mutated())
def test_mutated_scenes_parse_or_raise_a_located_scene_error(folder, data):
    event(check_parse(folder / "scene.txt", data))     # --hypothesis-show-statistics


def test_sources_parse_and_truncations_are_handled(folder):
    """Every original and bundled scene parses as it is; cut after each of its lines, it
    parses or raises the located error (a deterministic sweep next to the random one)."""
    if TUTORIAL.is_dir():
        assert {"page1/scene.txt", "page2/scene.txt", "page4/scene.txt"} <= set(SOURCES)
    assert {"scenes/page1.txt", "scenes/page4.txt"} <= set(SOURCES)
    outcomes = set()
    for name, data in SOURCES.items():
        assert check_parse(folder / "scene.txt", data) == "parsed", name
        cuts = [m.end() for m in re.finditer(rb"\n", data)]
        for cut in cuts[::3]:
            outcomes.add(check_parse(folder / "scene.txt", data[:cut]))
    assert outcomes == {"parsed", "error"}
