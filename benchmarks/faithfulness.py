"""Converted scenes rendered through Mitsuba against the port's strict output, byte for byte.

    python benchmarks/faithfulness.py [--pages 1 2] [--write-results [PATH]]

For each deterministic page, the bundled converted scene (``scenes/pageN.xml``, what
``codermind convert`` makes of the tutorial's ``pageN/scene.txt``) is rendered through the
tutorial pipeline (``codermind.tutorial.render``, seed 0) with the converter's
``min_distance`` and with ``min_distance`` 0 (Mitsuba's own ray offsets), and its 8-bit image
is compared with the port's strict render of ``scenes/pageN.txt``: bytes that differ, pixels,
bytes off by one level, and the pixels off by more, by where they lie (column x = 320, the
mirror plane where two spheres meet a ray at the same t; a sphere's silhouette; elsewhere).
Where the tutorial's files are present ($CODERMIND_TUTORIAL or ../shared/tutorial), the
port's strict page 1 is also compared with the original's ``page1/expected.png``.
"""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np

import _results

ROOT = _results.ROOT
PAGE = "faithfulness.md"


def counts(ours: np.ndarray, port) -> list:
    """[bytes differing, pixels, bytes by one level, tie / silhouette / elsewhere pixels]."""
    diff = np.abs(ours.astype(int) - port.rgb8.astype(int))
    ys, xs = np.nonzero(diff.max(-1) > 1)
    h = diff.shape[0]
    ty = (h - 1 - ys) * 480 / h
    tx = xs * 640 / diff.shape[1]
    edge = np.min([np.abs(np.hypot(tx - s.center[0], ty - s.center[1]) - s.size)
                   for s in port.scene.spheres], axis=0) if len(xs) else np.zeros(0)
    tie = np.abs(tx - 320) < 0.5 * 640 / diff.shape[1]
    silhouette = (edge < 1) & ~tie
    rest = ~tie & ~silhouette
    return [int((diff > 0).sum()), int((diff.max(-1) > 0).sum()), int((diff == 1).sum()),
            f"{int(tie.sum())} / {int(silhouette.sum())} / {int(rest.sum())}"]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pages", type=int, nargs="+", default=[1, 2])
    _results.add_argument(ap, PAGE)
    args = ap.parse_args(argv)
    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")
    import codermind  # noqa: F401  (registers the plugins)
    import codermind_ref as ref
    from codermind.tutorial import render as tr
    t0 = time.time()
    rows = []
    for page in args.pages:
        port = ref.render(ref.parse_scene(ROOT / "scenes" / f"page{page}.txt"), mode="strict")
        for label, defines in (("the converter's (0.1)", {}), ("0 (Mitsuba's offsets)",
                                                                {"min_distance": "0"})):
            scene, settings = tr.load(ROOT / "scenes" / f"page{page}.xml", **defines)
            res = tr.render(scene, settings, seed=0)
            row = [f"page {page}", label, f"{port.rgb8.size:,}"] + counts(res.image.rgb8, port)
            print(" | ".join(map(str, row)), flush=True)
            rows.append(row)
    body = ["## Mitsuba against the port's strict output", "",
            _results.table(["scene", "min_distance", "bytes", "bytes differing", "pixels",
                            "bytes by one level",
                            "pixels by more: tie column x = 320 / silhouette / elsewhere"],
                           rows)]
    expected = _results.TUTORIAL / "page1" / "expected.png"
    if 1 in args.pages and expected.is_file():
        from codermind_ref import png
        original = png.decode(expected.read_bytes())
        port = ref.render(ref.parse_scene(_results.TUTORIAL / "page1" / "scene.txt"),
                          mode="strict")
        differing = int((np.asarray(original)[..., :3] != port.rgb8).sum())
        body += ["## The port's strict output against the original's image", "",
                 _results.table(["scene", "bytes", "bytes differing from the original's "
                                 "`page1/expected.png`"],
                                [["the tutorial's `page1/scene.txt`", f"{port.rgb8.size:,}",
                                  differing]])]
        print(f"port strict vs expected.png: {differing} bytes differ")
    if args.write_results:
        _results.write(args.write_results, "\n".join(body), seconds=time.time() - t0)
    return 0


if __name__ == "__main__":
    sys.exit(main())
