"""One scene checked and ready to compare (:func:`prepare`), the options of ``codermind
compare`` and what both comparisons (against the port, against a reference image) share:
the Mitsuba side's XML and the rows outside the calibration strip."""

from __future__ import annotations

import os
import sys
from dataclasses import dataclass, field
from pathlib import Path

from . import refimage, sides
from .sides import Grid, HarnessError
from .verdict import Thresholds


@dataclass
class Options:
    spp: int | None = None        #: samples per sub-sample (default: sides.default_spp)
    seed: int = 0
    rect: tuple[int, int, int, int] | None = None
    stride: int = 1
    exposure: float | None = None
    blob_max_error: float | None = None
    port_mode: str = "clean"
    quirks: str = "clean"         #: the Mitsuba side's tutorialpath quirks (strict: port strict)
    out_dir: Path = Path("compare")
    defines: dict = field(default_factory=dict)
    thresholds: Thresholds = field(default_factory=Thresholds)
    progress: bool = True
    workers: int | None = None
    noise_floor: bool = False     #: also render the port with seed + 1 (FLIP of noise alone)
    exposure_seeds: int = 8       #: page 4: auto exposures per side for the exposure test
    reference: Path | None = None  #: a reference image as the other side (refimage)
    against: Path | None = None    #: an ordinary scene's other side, OTHER.xml (scene_compare)
    reference_variance: Path | None = None  #: an ordinary scene's reference variance image


def log(message: str) -> None:
    print(f"compare: {message}", file=sys.stderr, flush=True)


def labels(paths: list[str | os.PathLike]) -> list[str]:
    """A distinct file-name stem per scene: the file's stem, prefixed with its folder's name
    (and suffixed with its type) where two scenes would share it (``page1-scene``)."""
    paths = [Path(p) for p in paths]
    names = [p.stem for p in paths]
    for attempt in (lambda p: f"{p.parent.name}-{p.stem}",
                    lambda p: f"{p.parent.name}-{p.stem}-{p.suffix.lstrip('.')}"):
        if len(set(names)) == len(names):
            break
        names = [attempt(p) if names.count(n) > 1 else n for p, n in zip(paths, names)]
    seen: dict[str, int] = {}
    out = []
    for n in names:                         # the same file twice
        seen[n] = seen.get(n, 0) + 1
        out.append(n if seen[n] == 1 else f"{n}-{seen[n]}")
    return out


@dataclass
class Case:
    """A scene checked and ready to compare (:func:`prepare`)."""
    path: Path                    #: as given
    txt: Path                     #: the tutorial scene file
    xml: Path | None              #: the Mitsuba XML given, None: convert ``txt``
    scene: object                 #: codermind_ref.Scene
    grid: Grid
    random: bool
    spp: int
    reference: object = None      #: refimage.Reference, or None: the port is the other side


def prepare(path: str | os.PathLike, opt: Options) -> Case:
    """Everything about one scene that can be wrong before rendering (its twin, its parse, the
    grid, the options for its page), as a HarnessError naming the problem."""
    txt, xml = sides.twin_of(path)
    scene = sides.parse(txt)
    random = sides.is_random(scene)
    spp = opt.spp or (sides.default_spp(scene) if opt.reference is None
                      else reference_spp(scene, random))
    if spp < 1:
        raise HarnessError(f"--spp must be >= 1, got {spp}")
    if random and spp < 2:
        raise HarnessError(f"{txt}: a random scene needs --spp >= 2 (both sides estimate "
                           "their variance from their samples)")
    if opt.exposure is not None and scene.page == 1:
        raise HarnessError(f"{txt}: page 1 has no exposure")
    if opt.exposure_seeds < 2:
        raise HarnessError(f"--exposure-seeds: must be >= 2 (the test estimates each side's "
                           f"spread), got {opt.exposure_seeds}")
    grid = Grid.of(scene.width, scene.height, scene.page, opt.rect, opt.stride)
    strip_free_rows(grid, scene.page)
    ref = None
    if opt.reference is not None:
        ref = refimage.read(opt.reference, scene.width, scene.height, grid.sub)
    return Case(Path(path), txt, xml, scene, grid, random, spp, ref)


def reference_spp(scene, random: bool) -> int:
    """Default samples against a reference image: 1 without randomness, else the scene's
    Complexity (what the tutorial's program renders with, at least 2): the statistical tests
    assume the reference has our side's noise."""
    return max(scene.complexity, 2) if random else 1


def mitsuba_xml(case: Case, opt: Options, label: str, out: Path) -> tuple[Path, dict]:
    """The Mitsuba side's XML (``case.xml``, or ``case.txt`` converted into ``out``) and the
    XML defines the options ask for."""
    txt, xml, scene = case.txt, case.xml, case.scene
    if xml is None:
        xml = sides.convert_xml(txt, scene, out, opt.blob_max_error, name=f"{label}.mitsuba.xml",
                                quirks=opt.quirks)
        defines = dict(opt.defines)
    else:
        defines = dict(opt.defines)
        if opt.quirks != "clean":
            if '<default name="quirks"' not in xml.read_text(encoding="utf-8"):
                raise HarnessError(f"{xml}: no tutorialpath integrator with a quirks default "
                                   "(convert it again without --integrator path)")
            defines["quirks"] = opt.quirks
        if opt.blob_max_error is not None:
            defines.update({f"blob{i}_max_error": str(opt.blob_max_error)
                            for i in range(len(scene.blobs))})
    defines["spp"] = str(case.spp)
    return xml, defines


def strip_free_rows(grid: Grid, page: int) -> slice:
    """Display rows of the grid's image that are rendered (pages 2 and 4 replace tutorial rows
    y < 10 by the calibration strip, which both sides write identically)."""
    if page == 1:
        return slice(None)
    keep = int((grid.ys >= 10).sum())
    if keep == 0:
        raise HarnessError("the grid lies entirely in the calibration strip (y < 10)")
    return slice(0, keep)
