"""The power of `codermind compare`: known errors injected into the Mitsuba side (an edited
copy of the converted XML, or an XML default), each compared with the port at compare's
default settings on a small grid; which are caught, by which test, and the smallest size
caught. Writes a Markdown table (--out) and the records as JSON beside it; --write-results
writes the table to docs/results/harness-power.md.

    python benchmarks/harness_power.py [--only NAME ...] [--cluster ADDRESS] [--write-results [PATH]]

With --cluster each case is one Dask task: its scene text, edited XML and the files they name
(the cube-map faces, sent once per page) travel with it; the client writes the table.
"""

from __future__ import annotations

import argparse
import json
import re
import sys
import tempfile
import time
from pathlib import Path

import _results

ROOT = _results.ROOT
SCENES = ROOT / "scenes"

#: Grids: page 1 every 4th pixel (deterministic); page 4: the marble sphere and the floor
#: (lens blur, turbulence, bump), a patch of the glass blob, and the blob where Light0 lands.
GRIDS = {"page1": ("page1", None, 4), "page4-marble": ("page4", (392, 130, 440, 170), 1),
         "page4-blob": ("page4", (300, 250, 332, 274), 1),
         # where Light0 lands, on the blob (it lights 0.2 % of the frame, 36 % of this crop)
         "page4-light0": ("page4", (56, 248, 88, 272), 1),
         # the bounding box of every sub-sample whose first hit Light0 lights: its lit
         # group (sides.geometry_groups) is the full frame's
         "page4-light0-area": ("page4", (54, 97, 243, 348), 1)}


def scale_rgb(old: str, factor: float) -> str:
    return ", ".join(f"{float(v) * factor:.6g}" for v in old.split(","))


def rgb_edit(pattern: str, factor: float):
    """Scale the first <rgb> whose line matches ``pattern`` (a regex on the element)."""
    def edit(text: str) -> str:
        m = re.search(pattern, text)
        if m is None:
            raise SystemExit(f"no match for {pattern}")
        return text[:m.start(1)] + scale_rgb(m.group(1), factor) + text[m.end(1):]
    return edit


def value_edit(name: str, old: str, new: str, nth: int = 0):
    def edit(text: str) -> str:
        needle = f'name="{name}" value="{old}"'
        k = -1
        for _ in range(nth + 1):
            k = text.index(needle, k + 1)
        return text[:k] + f'name="{name}" value="{new}"' + text[k + len(needle):]
    return edit


def gradient_edit(text: str) -> str:
    out = re.sub(r'(<texture type="(?:turbulence|marble|perlin)"[^>]*>)',
                 r'\1<string name="gradient" value="reference"/>', text)
    return re.sub(r'(<bsdf type="noisebump"[^>]*>)', r'\1<string name="gradient" value="reference"/>',
                  out)


def cases():
    """(error, size label, grid, XML edit or None, defines)."""
    out = []
    for pct in (1, 2, 5):
        f = 1 + pct / 100
        out.append(("material colour", f"+{pct} %", "page1",
                    rgb_edit(r'<rgb name="diffuse" value="([^"]+)"', f), {}))
        out.append(("material colour", f"+{pct} %", "page4-marble",
                    rgb_edit(r'<rgb name="color0" value="([^"]+)"/>  <!-- Diffuse, line 77', f), {}))
        out.append(("light intensity", f"+{pct} %", "page1",
                    rgb_edit(r'<rgb name="intensity" value="([^"]+)"', f), {}))
        out.append(("light intensity", f"+{pct} %, Light0", "page4-marble",
                    rgb_edit(r'<rgb name="intensity" value="([^"]+)"', f), {}))
        out.append(("light intensity", f"+{pct} %, Light0", "page4-light0",
                    rgb_edit(r'<rgb name="intensity" value="([^"]+)"', f), {}))
        out.append(("light intensity", f"+{pct} %, Light1", "page4-marble",
                    rgb_edit(r'<rgb name="intensity" value="([^"]+)"/>  <!-- Intensity, line 114',
                             f), {}))
    for gname in ("page4-light0", "page4-light0-area"):
        out.append(("light intensity", "+3 %, Light0", gname,
                    rgb_edit(r'<rgb name="intensity" value="([^"]+)"', 1.03), {}))
    out.append(("refractive index", "2 -> 1.9", "page4-blob",
                value_edit("density", "2", "1.9"), {}))
    for new, label in (("0.09", "-10 %"), ("0.11", "+10 %")):
        out.append(("bumplevel", label, "page4-blob", value_edit("bumplevel", "0.1", new, 1), {}))
    out.append(("camera", "half a pixel (x)", "page1", value_edit("pixel_offset_x", "0", "1"), {}))
    out.append(("camera", "half a pixel (x)", "page4-marble",
                value_edit("pixel_offset_x", "0", "1"), {}))
    for new, label in (("9", "-10 %"), ("11", "+10 %")):
        out.append(("lens aperture", label, "page4-marble", value_edit("aperture", "10", new), {}))
    out.append(("one segment less", "max_depth 11 -> 10", "page1", None, {"max_depth": "10"}))
    out.append(("one segment less", "max_depth 11 -> 10", "page4-blob", None, {"max_depth": "10"}))
    out.append(("noise gradient", "gradient=reference", "page4-marble", gradient_edit, {}))
    out.append(("blob max_error", "x10", "page4-blob", None, {"blob0_max_error": "0.86487"}))
    out.append(("none (control)", "-", "page1", None, {}))
    out.append(("none (control)", "-", "page4-marble", None, {}))
    out.append(("none (control)", "-", "page4-blob", None, {}))
    out.append(("none (control)", "-", "page4-light0", None, {}))
    out.append(("none (control)", "-", "page4-light0-area", None, {}))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="/tmp/harness-power.md",
                    help="the table and, beside it, every case's record (.json)")
    ap.add_argument("--only", nargs="*", help="error names (substrings) to run")
    ap.add_argument("--cluster", metavar="ADDRESS",
                    help="tcp://HOST:PORT or local:N: one injected-error case per Dask task "
                         "(docs/cluster.md); the scene, the edited XML and the cube-map faces "
                         "travel with the tasks, the client writes the table")
    _results.add_argument(ap, "harness-power.md")
    args = ap.parse_args(argv)
    from codermind_harness.cluster import open_runner
    with open_runner(args.cluster) as runner:
        return run(args, runner)


#: ``Cubemap.Up = sky/skyup.tga;`` in a tutorial scene; ``<string name=".." value="FILE"/>``
#: in the XML: the files a case needs besides its two texts, relative to scenes/.
_TXT_FILE = re.compile(r"^\s*Cubemap\.\w+\s*=\s*([^;]+);", re.M)
_XML_FILE = re.compile(r'<string\s+name="[^"]+"\s+value="([^"]+)"')


def inputs(name: str) -> dict:
    """The files scenes/NAME.txt and scenes/NAME.xml name (relative path -> bytes)."""
    names = _TXT_FILE.findall((SCENES / f"{name}.txt").read_text(encoding="utf-8"))
    names += _XML_FILE.findall((SCENES / f"{name}.xml").read_text(encoding="utf-8"))
    return {n.strip(): (SCENES / n.strip()).read_bytes() for n in dict.fromkeys(names)
            if not Path(n.strip()).is_absolute() and (SCENES / n.strip()).is_file()}


def case_inputs(k: int, case: tuple) -> dict:
    """Case ``k``: what its task needs, as text and names (its files are shared per page)."""
    error, size, gname, edit, defines = case
    name, rect, stride = GRIDS[gname]
    text = (SCENES / f"{name}.xml").read_text(encoding="utf-8")
    if edit is not None:
        new = edit(text)
        assert new != text, (error, size)
        text = new
    return {"k": k, "error": error, "size": size, "grid": gname, "name": name, "rect": rect,
            "stride": stride, "defines": dict(defines), "xml": text,
            "txt": (SCENES / f"{name}.txt").read_text(encoding="utf-8")}


def run_case(case: dict, files: dict) -> dict:
    """One injected error compared with the port at compare's defaults, in a private folder
    (on a worker: nothing read from this repository's scenes/); its table row."""
    import mitsuba as mi
    if mi.variant() != "llvm_ad_rgb":
        mi.set_variant("llvm_ad_rgb")
    import codermind  # noqa: F401
    from codermind_harness.compare import Options, compare_scene, prepare
    name = case["name"]
    with tempfile.TemporaryDirectory(prefix="harness_power_") as tmp:
        folder = Path(tmp)
        for rel, data in files.items():
            (folder / rel).parent.mkdir(parents=True, exist_ok=True)
            (folder / rel).write_bytes(data)
        (folder / f"{name}.txt").write_text(case["txt"], encoding="utf-8")
        xml = folder / f"{name}.xml"
        xml.write_text(case["xml"], encoding="utf-8")
        opt = Options(rect=case["rect"], stride=case["stride"], out_dir=folder / "out",
                      defines=dict(case["defines"]), progress=False, workers=2)
        t0 = time.perf_counter()
        rec = compare_scene(prepare(xml, opt), opt, f"{name}-{case['k']}")
        seconds = time.perf_counter() - t0
    return {"error": case["error"], "size": case["size"], "grid": case["grid"],
            "caught": not rec["passed"], "failures": rec["failures"],
            "pass_rate": rec["z_test"]["pass_rate"], "flip": rec["flip_mean"],
            "flip_limit": rec.get("flip_limit"),
            "pooled": {k2: v["max_abs_z"] for k2, v in (rec.get("pooled") or {}).items()},
            "exposure_p": (rec["exposure_test"] or {}).get("p"), "seconds": seconds}


def run(args: argparse.Namespace, runner) -> int:
    chosen = [case_inputs(k, c) for k, c in enumerate(cases())
              if not args.only or any(o in c[0] for o in args.only)]
    files = {name: inputs(name) for name in dict.fromkeys(c["name"] for c in chosen)}
    if not runner.remote:
        rows = (run_case(c, files[c["name"]]) for c in chosen)
    else:                       # one task per case; each page's files sent once
        shared = {name: runner.share(f) for name, f in files.items()}
        rows = runner.results(runner.submit_all(
            run_case, [(c, shared[c["name"]]) for c in chosen]))
    done = []
    for row in rows:        # in case order, as they come back
        done.append(row)
        print(f"{row['error']:18s} {row['size']:20s} {row['grid']:13s} "
              f"{'CAUGHT' if row['caught'] else 'missed'}  pass {row['pass_rate']:.4f} "
              f"FLIP {row['flip']:.4f}/{row['flip_limit'] or 0:.4f} pooled {row['pooled']} "
              f"E p {row['exposure_p']} ({row['seconds']:.0f} s)", flush=True)
    out = Path(args.out)
    write(out.with_suffix(".json"), json.dumps(done, indent=2) + "\n")
    write(out, markdown(done, " ".join(sys.argv[1:])))
    if args.write_results:
        _results.write(args.write_results, markdown(done, ""))
    return 0


def write(path: Path, text: str) -> None:
    """Atomically: a reader never sees half a table."""
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(text)
    tmp.replace(path)


def which(failures: list[str]) -> str:
    """The tests that failed, in short."""
    keys = (("z-test", "z-test"), ("pooled z over tiles", "tiles"),
            ("pooled z over objects", "objects"), ("mean FLIP", "FLIP"),
            ("auto exposure", "exposure"))
    return ", ".join(short for key, short in keys if any(f.startswith(key) for f in failures))


def markdown(rows: list[dict], argv: str) -> str:
    lines = ["| error | size | grid | caught | by | z pass rate | pooled max Z (tiles / objects) "
             "| FLIP / limit | exposure p |", "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for r in rows:
        pooled = " / ".join(f"{v:.3g}" for v in r["pooled"].values()) or "-"
        lines.append(f"| {r['error']} | {r['size']} | {r['grid']} | "
                     f"{'**yes**' if r['caught'] else 'no'} | {which(r['failures']) or '-'} | "
                     f"{r['pass_rate']:.4f} | {pooled} | {r['flip']:.4f} / "
                     f"{(r['flip_limit'] or 0):.4f} | "
                     f"{'-' if r['exposure_p'] is None else format(r['exposure_p'], '.2g')} |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    sys.exit(main())
