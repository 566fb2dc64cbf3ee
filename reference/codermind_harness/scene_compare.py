"""``codermind compare`` on any Mitsuba scene, not only a tutorial scene: a user's own XML
against another render of it.

* ``--against OTHER.xml``: SCENE and OTHER (the same scene another way: another integrator,
  a built-in stand-in for a plugin, an edited copy), both rendered by Mitsuba in this
  process's variant, with the same XML defines and sample count, SCENE with ``seed``,
  OTHER with ``seed + 1``;
* ``--reference IMAGE.exr``: SCENE against a linear image of the same film size made
  elsewhere, with the variance of each of its pixels' means from ``--reference-variance
  FILE`` or ``IMAGE.variance.exr`` next to it (what ``codermind render --variance``
  writes); without one, the reference is taken to be as noisy as our side (its variance
  estimated by our second render, the noise floor's), which is right for a reference
  rendered at our sample count and conservative for a less noisy one, and the far-|z| rule
  is not applied.

Each render estimates every pixel's variance from its pass means, as the tutorial
comparison does (``sides.plain_side``: >= 16 passes with distinct seeds, degrees of freedom
passes - 1). SCENE is rendered once more with another seed (``seed + 2``; ``seed + 1``
against a reference): the noise floor of FLIP. The tests (:func:`measure`) are those of a
random tutorial scene against the port, on film pixels instead of sub-samples: the
per-pixel two-sample z-test (:func:`metrics.z_test`, Sidak-corrected), the pooled
difference (:func:`metrics.pooled_difference`) over tiles of 16 x 16 pixels, over the
objects (the shape each pixel's centre ray meets first in SCENE; the background is one
group) and over the whole image, with both sides' variances multiplied by the film's
:func:`sides.pooled_inflation` (a reconstruction filter wider than a pixel splats each
sample into several pixels: Mitsuba's default Gaussian makes a large group's sum pi times
as variable as its pixels' variances add up to), FLIP on the displayed images (clipped, sRGB) against the
noise floor (:func:`metrics.flip_limit`), and relative MSE; the verdict is
:func:`verdict.scene_failures`. The record, the heat map and the table row have the same
form as a tutorial scene's (:mod:`.report`).
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from . import metrics, refimage, report, sides, verdict
from .case import Options, log
from .runner import LOCAL, Runner
from .sides import Grid, HarnessError, SideImage
from .verdict import SceneTests, Thresholds

#: Samples per pixel by default: the scene's own sample count, at least MIN_SPP (the
#: variance of each side comes from 16 passes; docs/results/compare-any.md measures what
#: the default catches).
MIN_SPP = 32
#: The name of a reference's variance image next to it: ``codermind render --variance``'s.
VARIANCE_SUFFIX = ".variance.exr"


@dataclass
class SceneCase:
    """An ordinary scene checked and ready to compare (:func:`prepare`)."""
    path: Path
    other: Path | None                      #: --against
    reference: refimage.Reference | None    #: --reference (linear)
    variance: refimage.Reference | None     #: the reference's variance image
    grid: Grid                              #: film pixels (sub = 1; rect y up)
    spp: int
    scene_spp: int                          #: the scene's own sampler count
    defines: dict


def is_ordinary(path, opt: Options) -> bool:
    """Whether ``path`` is compared as an ordinary Mitsuba scene: ``--against`` asks for it;
    otherwise an XML that is no tutorial scene (:func:`sides.is_converted`)."""
    return getattr(opt, "against", None) is not None or not sides.is_converted(path)


def prepare(path, opt: Options) -> SceneCase:
    """Everything about an ordinary scene that can be wrong before rendering: both files,
    their film sizes, the reference and its variance image, the options, as a HarnessError
    naming the problem."""
    path = Path(path)
    if not path.is_file():
        raise HarnessError(f"{path}: no such scene file")
    if path.suffix.lower() != ".xml":
        raise HarnessError(f"{path}: --against compares Mitsuba XML scenes (a tutorial scene "
                           "file is compared with the port: drop --against)")
    against = getattr(opt, "against", None)
    if against is None and opt.reference is None:
        raise HarnessError(f"{path}: not a tutorial scene (no converter header naming its "
                           f"source, and no {path.with_suffix('.txt').name} next to it): "
                           "compare it with --against OTHER.xml or --reference IMAGE.exr")
    if against is not None and opt.reference is not None:
        raise HarnessError("--against and --reference: give one other side")
    for name, given in (("--exposure", opt.exposure is not None),
                        ("--blob-max-error", opt.blob_max_error is not None),
                        ("--quirks strict", opt.quirks != "clean"),
                        ("--port-mode strict", opt.port_mode != "clean"),
                        ("--noise-floor", opt.noise_floor)):
        if given:
            raise HarnessError(f"{path}: {name} applies to tutorial scenes only (an ordinary "
                               "scene is rendered as it is; its noise floor always is)")
    defines = dict(opt.defines)
    width, height, scene_spp = sides.plain_film(path, defines)
    other = None
    if against is not None:
        other = Path(against)
        if not other.is_file():
            raise HarnessError(f"{other}: no such scene file (--against)")
        if other.suffix.lower() != ".xml":
            raise HarnessError(f"{other}: --against needs a Mitsuba XML scene")
        w, h, _ = sides.plain_film(other, defines)
        if (w, h) != (width, height):
            raise HarnessError(f"{other}: its film is {w}x{h}, but {path.name}'s is "
                               f"{width}x{height}")
    spp = opt.spp or max(scene_spp, MIN_SPP)
    if spp < 2:
        raise HarnessError(f"{path}: --spp must be >= 2 for an ordinary scene (each side "
                           "estimates its variance from its passes)")
    grid = Grid.of(width, height, 1, opt.rect, opt.stride)
    ref = var = None
    variance_path = getattr(opt, "reference_variance", None)
    if opt.reference is not None:
        ref_path = Path(opt.reference)
        if ref_path.suffix.lower() != ".exr":
            raise HarnessError(f"{ref_path}: an ordinary Mitsuba scene is compared with a "
                               "linear .exr reference (its film), not a .png or .tga")
        if not ref_path.is_file():
            raise HarnessError(f"{ref_path}: no such reference image")
        ref = refimage.read(ref_path, width, height, 1)
        if variance_path is None:
            beside = variance_beside(ref_path)
            variance_path = beside if beside.is_file() else None
        if variance_path is not None:
            var = read_variance(Path(variance_path), width, height)
    elif variance_path is not None:
        raise HarnessError("--reference-variance: give it with --reference IMAGE.exr")
    return SceneCase(path, other, ref, var, grid, spp, scene_spp, defines)


def variance_beside(reference: Path) -> Path:
    """``IMAGE.variance.exr`` for ``IMAGE.exr``: ``codermind render --variance``'s name."""
    return reference.with_name(reference.name[:-len(reference.suffix)] + VARIANCE_SUFFIX)


def read_variance(path: Path, width: int, height: int) -> refimage.Reference:
    """The variance of each reference pixel's mean (linear EXR, the film's size, >= 0)."""
    if path.suffix.lower() != ".exr":
        raise HarnessError(f"{path}: a reference's variance image must be an .exr")
    if not path.is_file():
        raise HarnessError(f"{path}: no such variance image (--reference-variance)")
    v = refimage.read(path, width, height, 1)
    if (v.image < 0).any():
        raise HarnessError(f"{path}: {int((v.image < 0).sum())} negative variances")
    return v


def compare(case: SceneCase, opt: Options, label: str, out: Path,
            runner: Runner = LOCAL) -> dict:
    """One ordinary scene against OTHER or a reference image; returns its JSON record and
    writes its heat map. The renders are units of ``runner`` (SCENE's two seeds one unit,
    OTHER another, in flight together on a remote runner)."""
    import mitsuba as mi
    th, grid, spp = opt.thresholds, case.grid, case.spp
    t0 = time.perf_counter()
    against = case.other is not None
    other_name = case.other.name if against else case.reference.path.name
    floor_seed = opt.seed + 2 if against else opt.seed + 1
    log(f"{case.path.name}: {grid.width}x{grid.height} film, {grid.pixels} pixels, {spp} spp, "
        f"seed {opt.seed}, against {other_name}")
    handles = [sides.render_plain(case.path, grid, spp, (opt.seed, floor_seed), case.defines,
                                  labels=True, progress=opt.progress, runner=runner)]
    if against:
        handles.append(sides.render_plain(case.other, grid, spp, (opt.seed + 1,),
                                          case.defines, progress=opt.progress, runner=runner))
    done = list(runner.results(handles))
    (ours, floor), found, inflation = done[0]
    if against:
        (theirs,), _, other_inflation = done[1]
        inflation = max(inflation, other_inflation)
        noise = "OTHER's own, estimated from its passes"
    else:
        theirs, noise = reference_side(case, floor)
    t = measure(ours, theirs, floor, found, grid, th, inflation,
                judge_far=against or case.variance is not None)
    failures, flip_limit = verdict.scene_failures(t, grid.pixels, th)
    heatmap = out / f"{label}.compare.png"
    report.write_heatmap(heatmap, ours.encoded, theirs.encoded, slice(None), t.flip_map, t.z,
                         other_name, f"{label} against {other_name}: pass rate "
                         f"{t.z.pass_rate:.4f}, FLIP {t.flip_mean:.4f}, relMSE {t.rel_mse:.3g}",
                         left_label=case.path.name)
    return record(case, opt, label, mi.variant(), ours, theirs, floor, t, noise, failures,
                  flip_limit, heatmap, time.perf_counter() - t0, inflation)


def reference_side(case: SceneCase, floor: SideImage) -> tuple[SideImage, str]:
    """The reference image as the other side, with the variance of its pixels' means from
    its variance image (degrees of freedom taken to be our side's) or, without one, from our
    second render (``floor``: SCENE with another seed, independent of the render it is
    compared with, at our sample count), and what the verdict assumes about its noise."""
    grid = case.grid
    linear = case.reference.grid_film(grid)
    dof = floor.dof
    if case.variance is not None:
        variance = case.variance.grid_film(grid)
        noise = (f"its variance image {case.variance.path.name} (the variance of each "
                 f"pixel's mean; degrees of freedom taken as our side's, {dof})")
    else:
        variance = floor.variance
        noise = ("no variance image: assumed as noisy as our side (its variance estimated by "
                 "our second render's; right for a reference at our sample count, "
                 "conservative for a less noisy one); a |z| far beyond the Sidak bound is not "
                 "judged (the reference's own rare bright samples are in no variance estimate)")
    side = SideImage(case.reference.path.name, linear, variance, sides.encode_plain(linear),
                     0, 0.0, dof=dof)
    return side, noise


def measure(ours: SideImage, theirs: SideImage, floor: SideImage, found, grid: Grid,
            th: Thresholds, inflation: float = 1.0, judge_far: bool = True) -> SceneTests:
    """The tests of ``ours`` against ``theirs`` (no verdict: :func:`verdict.scene_failures`);
    ``floor``: ours with another seed; ``found``: (hit labels, shape names) or None;
    ``inflation``: the films' :func:`sides.pooled_inflation`, by which the pooled tests
    multiply both sides' variances (neighbouring pixels share samples); ``judge_far``:
    whether the far-|z| rule applies (both sides' variances estimated from their own
    samples)."""
    args = (ours.linear, ours.variance, theirs.linear, theirs.variance)
    z = metrics.z_test(*args, th.alpha, th.rtol, th.atol)
    dofs = [np.inf if s.dof is None else s.dof for s in (ours, theirs)]
    sz = np.abs(metrics.signed_z(*args, th.rtol, th.atol, *dofs))
    far_z = far_where = None
    if np.isfinite(sz).any():
        row, col, c = np.unravel_index(int(np.nanargmax(sz)), sz.shape)
        far_z = float(sz[row, col, c])
        far_where = (int(grid.xs[col]), int(grid.ys[::-1][row]), int(c))
    shape = ours.linear.shape[:2]
    # per-pixel tests above; the pooled sums below see the covariance of neighbours
    args = (ours.linear, ours.variance * inflation, theirs.linear, theirs.variance * inflation)
    pooled = {"tiles": metrics.pooled_difference(*args, metrics.tile_labels(shape), "tiles",
                                                 *dofs, th.pooled_alpha, th.rtol, th.atol)}
    if found is not None:
        labels_, names = found
        labels_ = np.where(labels_ < 0, len(names), labels_)
        pooled["objects"] = metrics.pooled_difference(*args, labels_, "objects", *dofs,
                                                      th.pooled_alpha, th.rtol, th.atol,
                                                      names=names + ["background"])
    pooled["image"] = metrics.pooled_difference(*args, np.zeros(shape, np.int64), "image",
                                                *dofs, th.pooled_alpha, th.rtol, th.atol,
                                                names=["image"])
    flip_mean, flip_map = metrics.flip(theirs.encoded, ours.encoded)
    flip_noise = metrics.flip(floor.encoded, ours.encoded)[0]
    rel_noise = float(np.mean((ours.variance + theirs.variance)
                              / (np.square(theirs.linear) + metrics.REL_MSE_EPS)))
    return SceneTests(z, far_z, far_where, flip_mean, flip_map, flip_noise,
                      metrics.rel_mse(ours.linear, theirs.linear), rel_noise,
                      {k: asdict(v) for k, v in pooled.items()}, judge_far)


def record(case: SceneCase, opt: Options, label: str, variant: str, ours: SideImage,
           theirs: SideImage, floor: SideImage, t: SceneTests, noise: str, failures: list,
           flip_limit: float, heatmap: Path, seconds: float, inflation: float) -> dict:
    """One ordinary scene's JSON record (``ordinary``: true; the tutorial records' keys
    where they mean the same)."""
    th, z, grid = opt.thresholds, t.z, case.grid
    against = case.other is not None
    return {
        "scene": str(case.path), "label": label, "ordinary": True,
        "against": str(case.other) if against else None,
        "reference": None if against else str(case.reference.path),
        "reference_variance": (None if against or case.variance is None
                               else str(case.variance.path)),
        "other_noise": noise, "variant": variant,
        "width": grid.width, "height": grid.height, "rect": list(grid.rect),
        "stride": grid.stride, "pixels": grid.pixels, "spp": case.spp,
        "scene_spp": case.scene_spp, "passes": None if ours.dof is None else ours.dof + 1,
        "seed": opt.seed,
        "seeds": {"scene": opt.seed, "other": opt.seed + 1 if against else None,
                  "noise_floor": opt.seed + 2 if against else opt.seed + 1},
        "defines": case.defines,
        "z_test": report.z_record(z, th, "pixels"),
        "z_far": {"max_abs_z": t.far_z, "judged": t.far_judged,
                  "at": None if t.far_where is None else list(t.far_where),
                  "factor": verdict.SCENE_Z_FAR,
                  "bound": verdict.SCENE_Z_FAR * z.z_critical},
        "pooled": t.pooled, "pooled_inflation": inflation, "flip_mean": t.flip_mean, "flip_noise": t.flip_noise,
        "flip_limit": flip_limit, "rel_mse": t.rel_mse, "rel_mse_noise": t.rel_mse_noise,
        "thresholds": {"pass_rate": th.pass_rate, "alpha": th.alpha,
                       "pooled_alpha": th.pooled_alpha, "flip_k": th.flip_k,
                       "flip_k0": th.flip_k0, "flip_eps": th.flip_eps,
                       "z_far": verdict.SCENE_Z_FAR},
        "passed": not failures, "failures": failures,
        "seconds": {"scene": ours.seconds, "other": theirs.seconds,
                    "noise_floor": floor.seconds, "load": ours.load_seconds,
                    "total": seconds},
        "heatmap": str(heatmap),
    }
