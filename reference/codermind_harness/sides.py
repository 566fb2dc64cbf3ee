"""One tutorial scene rendered on both sides, at matched sample positions and counts.

* **Mitsuba**: the converted XML (``codermind convert``, full model: ``path`` with
  ``max_depth`` 11) rendered with ``codermind.tutorial.render``: lights summed as the tutorial
  does, ``spp`` samples per film pixel (= per tutorial sub-sample), the variance of each
  sub-sample's mean from >= 16 pass means.
* **Port**: ``codermind_ref.render`` in clean mode (or any mode) with Complexity = ``spp``.

Both see the same sub-sample positions (the pixel's corner + {0, 1/2}^2, no jitter; page 1
the corner) and the same exposure (page 4: given, or the port's auto exposure for the seed;
page 2: 1). A :class:`Grid` picks part of the image: ``rect`` (half-open, tutorial pixel
coordinates, y up) and ``stride`` (every stride-th pixel). The port renders only those
pixels; Mitsuba renders the rectangle (a film crop) and the grid is taken from it.

Page 4 also yields each side's auto exposure for a list of seeds (:func:`port_exposures`;
``render_mitsuba(..., exposure_seeds=...)``): the port's from its probe grid, Mitsuba's from
the converted XML's ``probes`` sensor traced with its integrator
(``codermind.tutorial.render.probe_exposure``), lights summed as for the image, the
material roulette's diffuse event drawn as the original draws it (``probe_integrator``).

A scene without randomness (no lens blur, every roulette event certain:
``codermind.tutorial.model``) is rendered with one sample on both sides; its variance is 0
by construction on both (the port reports NaN for one ray on page 4, which is then 0).
"""

from __future__ import annotations

import math
import os
import re
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

import codermind_ref as ref

from .bundle import Bundle
from .progress import PortProgress
from .runner import LOCAL, Runner

#: The converted XML's header names its source file: "Converted by `codermind convert`
#: from NAME (scene version ..." (codermind.tutorial.xml).
_SOURCE = re.compile(r"Converted by `codermind convert` from (?P<name>.+?) \(scene version")
_FILM = re.compile(r'<film\b[^>]*\btype="hdrfilm"[^>]*>')
#: Samples per sub-sample of a random scene when its Complexity is lower. FLIP compares two
#: independently noisy images, so their noise alone must stay below the FLIP threshold:
#: page 4 at 16 samples gives 0.0143 port against port (seeds 0 and 1), at 64 0.0087.
MIN_RANDOM_SPP = 64


class HarnessError(Exception):
    """A user error (bad scene, bad option); the CLI prints it on one line."""


@dataclass(frozen=True)
class Grid:
    """Pixels of a ``width`` x ``height`` tutorial image: ``xs`` x ``ys`` (y up)."""
    width: int
    height: int
    sub: int                                  #: sub-samples per axis: 1 (page 1) or 2
    rect: tuple[int, int, int, int]
    stride: int = 1

    @classmethod
    def of(cls, width: int, height: int, page: int, rect=None, stride: int = 1) -> "Grid":
        rect = tuple(int(v) for v in (rect or (0, 0, width, height)))
        x0, y0, x1, y1 = rect
        if not (0 <= x0 < x1 <= width and 0 <= y0 < y1 <= height):
            raise HarnessError(f"--rect {x0},{y0},{x1},{y1} is not inside the {width}x{height} "
                               "image (x0,y0,x1,y1, half-open, y up)")
        if stride < 1:
            raise HarnessError(f"--stride must be >= 1, got {stride}")
        return cls(width, height, 1 if page == 1 else 2, rect, int(stride))

    @property
    def xs(self) -> np.ndarray:
        return np.arange(self.rect[0], self.rect[2], self.stride)

    @property
    def ys(self) -> np.ndarray:
        return np.arange(self.rect[1], self.rect[3], self.stride)

    @property
    def pixels(self) -> int:
        return self.xs.size * self.ys.size

    @property
    def full(self) -> bool:
        return self.rect == (0, 0, self.width, self.height) and self.stride == 1

    def crop(self) -> tuple[tuple[int, int], tuple[int, int]]:
        """Film crop (offset, size) in film pixels covering ``rect`` (film row 0 = top)."""
        x0, y0, x1, y1 = self.rect
        k = self.sub
        return (k * x0, k * (self.height - y1)), (k * (x1 - x0), k * (y1 - y0))

    def take(self, cropped: np.ndarray) -> np.ndarray:
        """The grid's sub-samples, display order, from the cropped film."""
        k, (x0, _, _, y1) = self.sub, self.rect
        xs, ys = self.xs, self.ys
        cols = (k * (xs - x0))[:, None] + np.arange(k)[None, :]            # (w, a)
        rows = (k * (y1 - 1 - ys))[:, None] + (k - 1 - np.arange(k))[None, :]   # (h, b)
        rows = rows[::-1, ::-1].ravel()            # display order: top row, then b = 1 first
        return cropped[rows][:, cols.ravel()]


@dataclass
class SideImage:
    """One side's render of a grid (display order)."""
    label: str
    linear: np.ndarray       #: float64 (k h, k w, 3) mean radiance per sub-sample
    variance: np.ndarray     #: float64, same: variance of that mean
    encoded: np.ndarray      #: float64 (h, w, 3): the displayed image before 8 bits, in [0, 1]
    spp: int
    seconds: float           #: rendering (and, for Mitsuba, loading) wall time
    load_seconds: float = 0.0
    probe_exposures: list[float] | None = None   #: auto exposure per seed asked for
    probe_seconds: float = 0.0
    dof: int | None = None   #: degrees of freedom of ``variance`` (Mitsuba: passes - 1, the
                             #: port: rays - 1); None: not estimated


@dataclass
class Renders:
    """One scene rendered on both sides at one exposure (``compare.render_sides``)."""
    xml: Path                               #: the Mitsuba side's XML
    defines: dict                           #: its XML defines
    exposure: float | None                  #: of both images
    seeds: list[int]                        #: page 4: the exposure test's seeds
    port_exposures: list[float] | None      #: the port's auto exposure for each seed
    port_probe_seconds: float
    port: SideImage                         #: either tie rule where they differ
    mits: SideImage
    own: SideImage                          #: the port as rendered (first tie rule)
    again: SideImage | None = None          #: the port with seed + 1 (noise floor)
    ties: dict | None = None                #: pixels with a tie and how Mitsuba took them


# -- the scene and its twin ------------------------------------------------------------------

def twin_of(path: str | os.PathLike) -> tuple[Path, Path | None]:
    """(tutorial scene file, Mitsuba XML or None). A ``.txt`` is its own twin (the XML is
    converted); an ``.xml``'s twin is the source file its converter header names, looked up in
    the XML's folder, else the ``.txt`` of the same name next to it."""
    path = Path(path)
    if not path.is_file():
        raise HarnessError(f"{path}: no such scene file")
    if path.suffix.lower() != ".xml":
        return path, None
    text = path.read_text(encoding="utf-8", errors="replace")
    m = _SOURCE.search(text)
    candidates = ([path.parent / m["name"]] if m else []) + [path.with_suffix(".txt")]
    for txt in candidates:
        if txt.is_file():
            return txt, path
    raise HarnessError(f"{path}: no tutorial twin: "
                       + (f"its header names {m['name']}, which is not in {path.parent}, "
                          if m else "no converter header naming its source, ")
                       + f"and there is no {path.with_suffix('.txt').name} next to it")


def is_converted(path: str | os.PathLike) -> bool:
    """Whether ``path`` is a tutorial scene for ``compare`` (:func:`twin_of` then finds its
    twin, or says why not): a scene file that is not an ``.xml``, an XML whose header names
    the converter's source, or one with a ``.txt`` of the same name next to it. Any other
    XML is an ordinary Mitsuba scene (:mod:`.scene_compare`)."""
    path = Path(path)
    if path.suffix.lower() != ".xml":
        return True
    if path.with_suffix(".txt").is_file():
        return True
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError:
        return True                 # twin_of says what is wrong with it
    return _SOURCE.search(text) is not None


def parse(txt: Path):
    try:
        return ref.parse_scene(txt)
    except ref.SceneError as e:
        raise HarnessError(str(e)) from None


def is_random(scene) -> bool:
    """Whether a sub-sample's rays differ (lens blur or a random roulette event)."""
    from codermind.tutorial.model import choose
    return choose(scene, exposure=1.0, max_depth=11, spp=1).stochastic


def default_spp(scene) -> int:
    """1 for a scene without randomness; else the scene's Complexity, at least
    :data:`MIN_RANDOM_SPP`."""
    if scene.page != 4 or not is_random(scene):
        return 1
    return max(scene.complexity, MIN_RANDOM_SPP)


def port_exposure(scene, seed: int, mode: str = "clean") -> float | None:
    """The port's exposure for ``seed``: page 4 auto (the probe grid), page 2: 1, page 1: None."""
    if scene.page == 1:
        return None
    if scene.page == 2:
        return 1.0
    return ref.render(scene, mode, seed, 1, rect=(0, 0, 1, 1), workers=1).exposure


def port_exposures(scene, seeds, mode: str = "clean") -> list[float] | None:
    """:func:`port_exposure` for each seed (page 4; None on other pages)."""
    if scene.page != 4:
        return None
    return [port_exposure(scene, int(s), mode) for s in seeds]


def convert_xml(txt: Path, scene, out_dir: Path, blob_max_error: float | None = None,
                name: str | None = None, quirks: str = "clean") -> Path:
    """The converter's XML of ``scene`` with the full model (``max_depth`` 11) and the
    ``tutorialpath`` integrator with ``quirks``, written to ``out_dir`` (cube-map faces named
    relative to it)."""
    from codermind.tutorial.convert import convert_scene
    from codermind.imageio import atomic_path
    xml = out_dir / (name or f"{txt.stem}.xml")
    conversion = convert_scene(scene, xml, max_depth=11, spp=1, blob_max_error=blob_max_error,
                               command=f"codermind convert {txt} --max-depth 11",
                               quirks=quirks)
    out_dir.mkdir(parents=True, exist_ok=True)
    with atomic_path(xml) as tmp:
        tmp.write_text(conversion.xml, encoding="utf-8")
    return xml


# -- Mitsuba ---------------------------------------------------------------------------------

def crop_xml(text: str, offset: tuple[int, int], size: tuple[int, int]) -> str:
    """``text`` with a crop window on its first ``hdrfilm`` (the rendered sensor's)."""
    m = _FILM.search(text)
    if m is None or m.group(0).endswith("/>"):
        raise HarnessError("cannot crop the film (no <film type=\"hdrfilm\"> element): use the "
                           "full image (no --rect)")
    props = "".join(f'<integer name="{n}" value="{v}"/>' for n, v in (
        ("crop_offset_x", offset[0]), ("crop_offset_y", offset[1]),
        ("crop_width", size[0]), ("crop_height", size[1])))
    return text[:m.end()] + props + text[m.end():]


_SENSOR = re.compile(r'<sensor\b[^>]*>')
_SAMPLER = re.compile(r'<sampler\b[^>]*?(?:/>|>.*?</sampler>)', re.S)
_SAMPLE_COUNT = re.compile(r'<integer\s+name="sample_count"[^>]*/>')


def iid_sampler_xml(text: str) -> str:
    """``text`` with the first sensor's sampler replaced by ``independent``
    (:func:`sampler_xml`): every sample of
    a sub-sample an independent draw, as the port's rays are. The pooled tests need both
    sides' sub-sample means to come from the same kind of estimator: a stratified sampler
    (``multijitter``) gives the same expectation with another distribution of the mean and
    of its variance estimate, and Stouffer's Z over thousands of signed z then drifts by
    several units with no difference in the rendering (docs/results/compare.md, the page-4
    blob)."""
    return sampler_xml(text, "independent")


def sampler_xml(text: str, kind: str) -> str:
    """``text`` with the first sensor's own sampler replaced by one of type ``kind``, keeping
    its ``sample_count`` element (it may read an XML default such as ``$spp``). A sensor
    without a sampler has Mitsuba's default, ``independent``: left alone for that kind,
    refused for another."""
    s = _SENSOR.search(text)
    m = None
    if s is not None and not s.group(0).endswith("/>"):
        end = text.find("</sensor>", s.end())
        m = _SAMPLER.search(text, s.end(), end if end >= 0 else len(text))
    if m is None:
        if kind == "independent":
            return text
        raise ValueError(f"no sensor sampler to replace by {kind!r}")
    count = _SAMPLE_COUNT.search(m.group(0))
    body = f'<sampler type="{kind}">{count.group(0)}</sampler>' if count else \
        f'<sampler type="{kind}"/>'
    return text[:m.start()] + body + text[m.end():]


_TUTORIALPATH = re.compile(r'<integrator\s+type="tutorialpath"\s*(/?)>')


def drawn_diffuse_xml(text: str) -> str:
    """``text`` with its ``tutorialpath`` integrator drawing the roulette's "diffuse" event
    as the tutorial does (``draw_diffuse``, facts.md F8.3: the lights at full weight where
    the draw picks it, the path ending there), where that integrator has the option
    (:func:`draws_diffuse`); else ``text`` as it is.

    The port draws that event; ``tutorialpath`` by default lights every hit times its
    probability 1 - Rf - Tr and goes on: the same expectation, another distribution per
    sample. A per-sub-sample test with variances estimated from 16 samples then compares
    a sampled event with a deterministic term: where the diffuse probability is 0.2, 0.8^16
    = 2.8 % of the port's sub-samples draw no diffuse event at all (variance 0, the lights
    missing) while Mitsuba's carry 0.2 times them, so |z| is infinite or in the hundreds
    on correct plugins (glass, partly reflecting metals and Fresnel-reflecting plastics on
    random scenes; tests/harness/test_random_compare.py); with both sides drawing, both
    estimate the same distribution, as the ``independent`` sampler makes their samples
    alike (:func:`iid_sampler_xml`)."""
    if 'name="draw_diffuse"' in text or not draws_diffuse():
        return text
    m = _TUTORIALPATH.search(text)
    if m is None:
        return text
    option = '<boolean name="draw_diffuse" value="true"/>'
    if m.group(1):          # <integrator type="tutorialpath"/>
        return (text[:m.start()] + f'<integrator type="tutorialpath">{option}</integrator>'
                + text[m.end():])
    return text[:m.end()] + option + text[m.end():]


_DRAWS: dict = {}


def draws_diffuse() -> bool:
    """Whether this Mitsuba variant's ``tutorialpath`` has the ``draw_diffuse`` option."""
    import mitsuba as mi
    variant = mi.variant()
    if variant not in _DRAWS:
        try:
            _DRAWS[variant] = hasattr(mi.load_dict({"type": "tutorialpath"}), "draw_diffuse")
        except (RuntimeError, ValueError, TypeError):
            _DRAWS[variant] = False
    return _DRAWS[variant]


def load_mitsuba(xml: Path, grid: Grid, defines: dict, iid: bool = False):
    """The scene of ``xml`` with the first sensor's film cropped to the grid's rectangle;
    with ``iid`` (a random scene), its sampler replaced by ``independent``
    (:func:`iid_sampler_xml`) and its ``tutorialpath`` drawing the diffuse event
    (:func:`drawn_diffuse_xml`)."""
    from codermind.errors import CodermindError
    from codermind.scene import load_scene
    from codermind.tutorial.render import read_settings
    settings = read_settings(xml)
    if settings is None:
        raise HarnessError(f"{xml}: not a converted tutorial scene (no codermind-tutorial "
                           "block)")
    if (settings.width, settings.height) != (grid.width, grid.height):
        raise HarnessError(f"{xml}: {settings.width}x{settings.height}, but its twin is "
                           f"{grid.width}x{grid.height}")
    try:
        full = grid.rect == (0, 0, grid.width, grid.height)
        if full and not iid:
            return load_scene(xml, **defines), settings
        text = xml.read_text(encoding="utf-8")
        if not full:
            text = crop_xml(text, *grid.crop())
        if iid:
            text = drawn_diffuse_xml(iid_sampler_xml(text))
        return _load_text(text, xml, defines), settings
    except CodermindError as e:
        raise HarnessError(str(e)) from None
    except (RuntimeError, ValueError, TypeError) as e:
        raise HarnessError(f"{xml}: {e}") from None


def _load_text(text: str, xml: Path, defines: dict):
    """``mi.load_string(text)`` with names resolved against ``xml``'s folder, as
    ``mi.load_file`` resolves them for its own file; the Python emitters attached."""
    import mitsuba as mi
    from codermind.scene import attach_emitters
    resolver = mi.file_resolver()
    saved = [resolver[i] for i in range(len(resolver))]
    resolver.prepend(str(xml.resolve().parent))   # as load_file does for its own folder
    try:
        # one thread: twice in CI a parallel load of a converted scene here failed inside
        # Mitsuba (basic_string::_M_create while instantiating a built-in plugin)
        scene = mi.load_string(text, parallel=False, **defines)
    finally:
        resolver.clear()
        for folder in saved:
            resolver.append(folder)
    attach_emitters(scene)
    return scene


def displayed(encoded: np.ndarray) -> np.ndarray:
    """The displayed value in [0, 1] of an encoded image before 8 bits, as the byte
    conversion shows it (``codermind_ref.tonemap.to_bytes``, x86): NaN is black (byte 0),
    above 1 white, below 0 black. Page 4's tone curve gives NaN where a sub-sample's radiance
    is negative (the unclamped turbulence mix, facts.md F7.2) and Power is not an integer
    (c^P); both sides compute it, FLIP refuses NaN."""
    return np.clip(np.nan_to_num(np.asarray(encoded, dtype=np.float64), nan=0.0, posinf=1.0,
                                 neginf=0.0), 0.0, 1.0)


def encode_mitsuba(linear: np.ndarray, settings, exposure: float | None) -> np.ndarray:
    """The displayed image before 8 bits, by the plugins' pipeline (codermind.tutorial.image)."""
    from codermind.tutorial.image import average_blocks, srgb_encode, tone_curve
    if settings.page == 1:
        return displayed(linear)
    e = 1.0 if exposure is None else float(exposure)
    return displayed(srgb_encode(average_blocks(tone_curve(e * linear, settings))))


def render_mitsuba(xml: Path, grid: Grid, spp: int, seed: int, exposure: float | None,
                   defines: dict | None = None, variance: bool = True,
                   progress: bool = True, exposure_seeds=(), iid: bool = False,
                   runner: Runner = LOCAL) -> SideImage:
    """The grid rendered from ``xml``; with ``exposure_seeds`` (page 4) also the auto
    exposure of the XML's probes for each of those seeds; with ``iid`` with the
    ``independent`` sampler (:func:`iid_sampler_xml`). One unit of ``runner``
    (:func:`mitsuba_side`), in this process's Mitsuba variant."""
    import mitsuba as mi        # heavy: Mitsuba and its JIT
    return runner.call(mitsuba_side, runner.ship(xml), grid, spp, seed, exposure,
                       dict(defines or {}), variance, mi.variant(), tuple(exposure_seeds), iid,
                       progress and not runner.remote)


#: Per process: the scenes loaded from bundles (a worker keeps them for the next task).
_LOADED: dict = {}


def mitsuba_side(xml: Path | Bundle, grid: Grid, spp: int, seed: int, exposure: float | None,
                 defines: dict, variance: bool, variant: str | None, exposure_seeds: tuple,
                 iid: bool, progress: bool) -> SideImage:
    """:func:`render_mitsuba` where the runner runs it: here (``xml`` a path) or in another
    process (a :class:`Bundle`, its loaded scene kept for the next task there)."""
    from codermind.passes import Progress      # heavy: Mitsuba (so are those below)
    from codermind.tutorial.render import probe_exposure, render_linear
    t0 = time.perf_counter()
    _use_variant(variant)
    if isinstance(xml, Path):
        scenes, settings = _load(xml, grid, defines, iid)
    else:
        key = (xml.digest, grid, tuple(sorted(defines.items())), variant, iid)
        if key not in _LOADED:
            _LOADED[key] = _load(xml.materialize(), grid, defines, iid)
        scenes, settings = _LOADED[key]
    t1 = time.perf_counter()
    bar = Progress(spp, label=f"mitsuba {xml.name}") if progress else None
    mean, var, done, times = render_linear(scenes, spp, seed, variance=variance, progress=bar)
    t2 = time.perf_counter()
    exposures = None
    if settings.page == 4 and len(exposure_seeds):
        exposures = [probe_exposure(scenes, settings, int(s)) for s in exposure_seeds]
    linear = grid.take(mean.astype(np.float64))
    var = grid.take(var.astype(np.float64)) if var is not None else np.zeros_like(linear)
    return SideImage("mitsuba", linear, var, encode_mitsuba(linear, settings, exposure),
                     done, t2 - t0, t1 - t0, exposures, time.perf_counter() - t2,
                     mitsuba_dof(variance, times))


def _load(xml: Path, grid: Grid, defines: dict, iid: bool):
    """(scene or its per-light scenes, settings) of ``xml``: the lights summed as the tutorial
    does where its settings say so."""
    from codermind.tutorial.render import light_scenes
    scene, settings = load_mitsuba(xml, grid, dict(defines), iid)
    return (light_scenes(scene) if settings.lights == "sum" else scene), settings


def _use_variant(name: str | None) -> None:
    """The Mitsuba variant ``name`` in this process (a no-op where it is set already), the
    plugins registered."""
    import mitsuba as mi
    if name is None or mi.variant() != name:
        from codermind.variants import set_variant
        set_variant(name)
    import codermind  # noqa: F401  (registers the plugins)


def mitsuba_dof(variance: bool, times: list) -> int | None:
    """Degrees of freedom of the variance ``render_linear`` estimates from its pass means."""
    return len(times) - 1 if variance and len(times) > 1 else None


# -- the port --------------------------------------------------------------------------------

def render_port(scene, grid: Grid, spp: int, seed: int, exposure: float | None,
                mode: str = "clean", random: bool | None = None, workers: int | None = None,
                progress: bool = True, ties: str = "first", runner: Runner = LOCAL
                ) -> SideImage:
    """The grid rendered by the port; its tiles as units of ``runner`` (a remote runner's
    under that runner's progress line)."""
    t0 = time.perf_counter()
    callback = (PortProgress(f"port {Path(scene.path).name}")
                if progress and not runner.remote else None)
    result = ref.render(scene, mode, seed, spp, exposure=exposure, rect=grid.rect,
                        stride=grid.stride, workers=workers, progress=callback,
                        tile_map=runner.tile_map, ties=ties)
    seconds = time.perf_counter() - t0
    var = result.variance.astype(np.float64)
    if np.isnan(var).any():
        if random is None:
            random = is_random(scene)
        if random:
            raise HarnessError(f"{scene.path}: the port cannot estimate a variance from one ray "
                               "per sub-sample of a random scene: use --spp >= 2")
        var = np.zeros_like(var)
    return SideImage(f"port ({result.mode})", result.linear.astype(np.float64), var,
                     displayed(result.encoded), result.complexity,
                     seconds, dof=result.complexity - 1 if result.complexity > 1 else None)


def either_tie(mits: SideImage, first: SideImage, last: SideImage, sub: int
               ) -> tuple[SideImage, int, int]:
    """The port's image with, at each pixel where its two tie rules differ (a ray meets two
    spheres at exactly the same distance, :class:`codermind_ref.world.World`), the rule whose
    sub-samples lie closer to Mitsuba's; the number of such pixels and of those that took
    "last". The original keeps the sphere listed first; Mitsuba's BVH has no such order."""
    k = sub

    def per_pixel(x: np.ndarray) -> np.ndarray:        # (k h, k w, 3) -> (h, w)
        h, w = x.shape[0] // k, x.shape[1] // k
        return x.reshape(h, k, w, k, 3).max(axis=(1, 3, 4))

    tie = per_pixel(np.abs(first.linear - last.linear)) > 0
    take = tie & (per_pixel(np.abs(mits.linear - last.linear))
                  < per_pixel(np.abs(mits.linear - first.linear)))
    sub_take = np.repeat(np.repeat(take, k, axis=0), k, axis=1)[:, :, None]
    linear = np.where(sub_take, last.linear, first.linear)
    encoded = np.where(take[:, :, None], last.encoded, first.encoded)
    merged = SideImage(first.label, linear, first.variance, encoded, first.spp,
                       first.seconds + last.seconds, dof=first.dof)
    return merged, int(tie.sum()), int(take.sum())


#: World units: the largest error of the blob meshes that only label sub-samples by object.
LABEL_BLOB_ERROR = 1.0
_DEFAULT = re.compile(r'<default\s+name="(blob_tessellate|blob\d+_max_error)"')


def object_labels(xml: Path, grid: Grid, defines: dict | None = None
                  ) -> tuple[np.ndarray, list[str]]:
    """Which shape each sub-sample of the grid sees first along the lens centre's ray
    (Mitsuba's intersection; -1: nothing, the sky), and the shapes' names. Pooling the
    z-test over these groups tests each object as a whole. A blob that the XML leaves
    without a mesh (``blob_tessellate`` false: ``tutorialpath`` intersects its zone field,
    Mitsuba's own intersection sees nothing there) is labelled through a mesh within
    :data:`LABEL_BLOB_ERROR` of its surface (a sub-sample at its silhouette may fall on
    either side; the groups only need to be fixed before the data are seen)."""
    g = geometry_groups(xml, grid, defines, lights=False)
    return g.labels, g.names


@dataclass
class Groups:
    """Groups of a grid's sub-samples fixed by the geometry alone (:func:`geometry_groups`)."""
    labels: np.ndarray          #: int (h, w): the shape seen first, -1: the sky
    names: list[str]            #: of the shapes
    lit: list[np.ndarray]       #: per delta light, bool (h, w): its light reaches that hit
    light_names: list[str]


def geometry_groups(xml: Path, grid: Grid, defines: dict | None = None, lights: bool = True
                    ) -> Groups:
    """:func:`object_labels`, and for each delta light (the tutorial's point lights) the
    sub-samples whose first hit it lights: the hit faces it (the side the camera sees) and
    nothing lies between (a shadow ray, Mitsuba's offsets, the plain distance). A light's
    error shows only where it lights, often a small part of the frame (page 4's Light0: about
    0.2 %), so its group pools exactly there instead of over a whole object."""
    import drjit as dr
    import mitsuba as mi
    defines = dict(defines or {})
    found = set(_DEFAULT.findall(xml.read_text(encoding="utf-8", errors="replace")))
    if "blob_tessellate" in found:
        defines["blob_tessellate"] = "true"
        defines.update({n: str(LABEL_BLOB_ERROR) for n in found if n.endswith("_max_error")})
    scene, _ = load_mitsuba(xml, grid, defines)
    ray, si, lab, names, (cw, ch) = _centre_hits(scene)
    lit, light_names = [], []
    if lights:
        valid = si.is_valid()
        n = mi.Vector3f(si.n)
        n = dr.select(dr.dot(n, ray.d) > 0, -n, n)          # the side the camera sees
        k = 0
        for e in scene.emitters():
            if not mi.has_flag(e.flags(), mi.EmitterFlags.Delta):
                continue
            ds, weight = e.sample_direction(si, mi.Point2f(0.5, 0.5), valid)
            reach = valid & (dr.dot(n, ds.d) > 0) & (dr.max(weight) > 0)
            blocked = scene.ray_test(si.spawn_ray_to(ds.p), reach)
            mask = np.array(reach & ~blocked, dtype=bool).reshape(ch, cw)
            lit.append(grid.take(mask))
            light_names.append(f"lit by {e.id() or f'light {k}'}")
            k += 1
    return Groups(grid.take(lab.reshape(ch, cw)), names, lit, light_names)


def _kind(shape) -> str:
    """A shape's kind for a label: the class name, the C++ one for built-in shapes (whose
    Python type is only Shape); a Python plugin's to_string may not be callable."""
    name = type(shape).__name__
    if name == "Shape":
        try:
            name = str(shape).split("[")[0].strip() or name
        except RuntimeError:
            pass
    return name.lower()


# -- any Mitsuba scene -----------------------------------------------------------------------

def load_plain(xml: Path, grid: Grid | None, defines: dict):
    """An ordinary Mitsuba scene (no tutorial pipeline: its own integrator, sampler and light
    sampling) with the XML ``defines``; with a ``grid`` that is not the whole film, its first
    film cropped to the grid's rectangle. A one-line HarnessError for what Mitsuba refuses."""
    from codermind.errors import CodermindError
    from codermind.scene import load_scene
    try:
        if grid is None or grid.rect == (0, 0, grid.width, grid.height):
            scene = load_scene(xml, **defines)
        else:
            scene = _load_text(crop_xml(xml.read_text(encoding="utf-8"), *grid.crop()), xml,
                               defines)
    except CodermindError as e:
        raise HarnessError(str(e)) from None
    except (RuntimeError, ValueError, TypeError) as e:
        raise HarnessError(f"{xml}: {' '.join(str(e).split())}") from None
    if not scene.sensors():
        raise HarnessError(f"{xml}: the scene has no sensor to render from")
    if scene.integrator() is None:
        raise HarnessError(f"{xml}: the scene has no integrator")
    return scene


def plain_film(xml: Path, defines: dict) -> tuple[int, int, int]:
    """(width, height, sample count) of the first sensor of ``xml`` with ``defines``."""
    scene = load_plain(xml, None, defines)
    sensor = scene.sensors()[0]
    w, h = (int(v) for v in sensor.film().size())
    return w, h, int(sensor.sampler().sample_count())


def encode_plain(linear: np.ndarray) -> np.ndarray:
    """The displayed image of an ordinary scene's linear film, before 8 bits: clipped to
    [0, 1] and sRGB-encoded (what ``codermind render`` writes to its PNG)."""
    from codermind.tutorial.image import srgb_encode
    return np.clip(srgb_encode(np.clip(linear, 0.0, 1.0)), 0.0, 1.0)


def render_plain(xml: Path, grid: Grid, spp: int, seeds, defines: dict | None = None,
                 labels: bool = False, progress: bool = True, runner: Runner = LOCAL):
    """Handles (for ``runner.results``) of :func:`plain_side`: ``xml`` rendered with each of
    ``seeds`` as one unit of ``runner``, in this process's Mitsuba variant."""
    import mitsuba as mi        # heavy: Mitsuba and its JIT
    return runner.submit_all(plain_side, [(runner.ship(xml), grid, spp, tuple(seeds),
                                          dict(defines or {}), mi.variant(), labels,
                                          progress and not runner.remote)])[0]


def plain_side(xml: Path | Bundle, grid: Grid, spp: int, seeds: tuple, defines: dict,
               variant: str | None, labels: bool, progress: bool
               ) -> tuple[list[SideImage], tuple | None, float]:
    """An ordinary scene's grid rendered once per seed (the scene loaded once), each render's
    variance estimated from its pass means as for a tutorial scene
    (``codermind.tutorial.render.render_linear``: >= 16 passes, degrees of freedom passes -
    1); with ``labels``, also the shape each grid pixel's centre ray meets first
    (:func:`hit_labels`); and its film's :func:`pooled_inflation`."""
    from codermind.passes import Progress      # heavy: Mitsuba (so are those below)
    from codermind.tutorial.render import render_linear
    t0 = time.perf_counter()
    _use_variant(variant)
    path = xml if isinstance(xml, Path) else xml.materialize()
    scene = load_plain(path, grid, defines)
    size = tuple(int(v) for v in scene.sensors()[0].film().size())
    if size != (grid.width, grid.height):
        raise HarnessError(f"{xml.name}: its film is {size[0]}x{size[1]}, not the "
                           f"{grid.width}x{grid.height} the comparison was prepared for")
    load = time.perf_counter() - t0
    out = []
    for seed in seeds:
        t1 = time.perf_counter()
        bar = Progress(spp, label=f"mitsuba {xml.name} seed {seed}") if progress else None
        try:
            mean, var, done, times = render_linear(scene, spp, int(seed), variance=True,
                                                   progress=bar)
        except (RuntimeError, ValueError) as e:     # e.g. a plugin refusing its scene
            raise HarnessError(f"{xml.name}: rendering failed: {' '.join(str(e).split())}"
                               ) from None
        linear = grid.take(mean.astype(np.float64))
        bad = int((~np.isfinite(linear)).sum())
        if bad:
            raise HarnessError(f"{xml.name}: the render with seed {seed} has {bad} NaN or "
                               "infinite values")
        v = grid.take(var.astype(np.float64))
        out.append(SideImage(xml.name, linear, v, encode_plain(linear), done,
                             time.perf_counter() - t1 + (load if not out else 0.0),
                             load if not out else 0.0, dof=mitsuba_dof(True, times)))
    found = hit_labels(scene, grid) if labels else None
    return out, found, pooled_inflation(scene.sensors()[0].film(), grid.stride)


def hit_labels(scene, grid: Grid) -> tuple[np.ndarray, list[str]]:
    """:func:`object_labels` of a loaded scene (an ordinary one) whose first sensor's film is
    cropped to the grid's rectangle: which shape each grid pixel's centre ray meets first
    (-1: nothing), and the shapes' names."""
    _, _, lab, names, (cw, ch) = _centre_hits(scene)
    return grid.take(lab.reshape(ch, cw)), names


def _centre_hits(scene):
    """The rays through the centres of the first sensor's (cropped) film pixels, their first
    intersections, the index of the shape each meets (-1: nothing), the shapes' names and
    the crop's size."""
    import drjit as dr
    import mitsuba as mi
    sensor = scene.sensors()[0]
    cw, ch = (int(v) for v in sensor.film().crop_size())
    j, i = np.meshgrid(np.arange(ch), np.arange(cw), indexing="ij")
    u = ((i.ravel() + 0.5) / cw).astype(np.float32)
    v = ((j.ravel() + 0.5) / ch).astype(np.float32)
    ray, _ = sensor.sample_ray(mi.Float(0.0), mi.Float(0.5),
                               mi.Point2f(mi.Float(u), mi.Float(v)), mi.Point2f(0.5, 0.5))
    si = scene.ray_intersect(ray)
    hit = np.array(si.is_valid(), dtype=bool)
    ptr = np.array(dr.reinterpret_array(mi.UInt32, si.shape), dtype=np.int64)
    shapes = scene.shapes()
    ids = np.array(dr.reinterpret_array(mi.UInt32, scene.shapes_dr()), dtype=np.int64)
    order = np.argsort(ids)
    pos = np.clip(np.searchsorted(ids[order], ptr), 0, ids.size - 1)
    lab = np.where(hit & (ids[order][pos] == ptr), order[pos], -1).astype(np.int64)
    names = [f"{k} {s.id() or _kind(s)}" for k, s in enumerate(shapes)]
    return ray, si, lab, names, (cw, ch)


def pooled_inflation(film, stride: int = 1) -> float:
    """var(sum of a group's pixel means) / (sum of their variances) for a group much wider
    than the film's reconstruction filter: each sample is splatted into every pixel within
    the filter's radius, so neighbouring pixels' means are correlated (1 for a box filter
    of one pixel; pi for Mitsuba's default, a Gaussian of sd 0.5 px). With samples spread
    uniformly and the filter separable, f(x) f(y), each pixel's mean normalised by its
    weight sum, the correlation of pixels d apart is g(d) / g(0), g(d) = int f(x) f(x - d) dx
    per axis, and the factor is (sum over integer d of g(d) / g(0))^2 (d a multiple of
    ``stride`` where the grid takes every stride-th pixel). A group's edge pixels
    have fewer correlated partners inside it, so the factor overstates the variance of a
    small group's sum (conservative)."""
    import drjit as dr
    import mitsuba as mi
    rf = film.rfilter()
    r = float(rf.radius())
    x = np.linspace(-r, r, 4001)
    if dr.is_jit_v(mi.Float):
        f = np.array(rf.eval(mi.Float(x.astype(np.float32))), dtype=np.float64)
    else:
        f = np.array([float(rf.eval(float(v))) for v in x])
    dx = x[1] - x[0]

    def g(d: int) -> float:
        return float(np.sum(f * np.interp(x - d, x, f, left=0.0, right=0.0)) * dx)

    g0 = g(0)
    if not g0 > 0:
        return 1.0
    reach = int(math.ceil(2 * r))
    k = sum(g(d) for d in range(-reach, reach + 1) if d % stride == 0) / g0
    return float(max(k, 1.0) ** 2)
