"""``codermind convert`` as a function: choose the model for a parsed scene (the caller parses
it, e.g. with the port's parser), write the XML atomically.

The page-4 depth bound may need the exposure E (:mod:`codermind.tutorial.model`); it is then
computed as ``codermind render`` computes it, by tracing the probe grid through Mitsuba, on
the full-depth version of the same XML (loaded from a string, faces named absolutely).
"""

from __future__ import annotations

import os
from dataclasses import dataclass

from ..errors import CodermindError
from ..imageio import atomic_path
from .finite import check_finite
from .model import DEFAULT_TARGET, FULL_DEPTH, choose
from .xml import Conversion, convert


@dataclass
class ConvertResult:
    conversion: Conversion
    parse_warnings: list[str]


def estimate_exposure(scene, target: float) -> float:
    """E of the full-depth model, from the probe grid traced through Mitsuba (llvm_ad_rgb)."""
    from ..variants import set_variant
    set_variant(None)
    import mitsuba as mi
    import codermind  # noqa: F401  (registers the plugins)
    from ..scene import attach_emitters
    from .render import probe_exposure
    full = choose(scene, target, max_depth=FULL_DEPTH + 1, spp=1, exposure=1.0)
    conversion = convert(scene, None, full)
    try:
        loaded = mi.load_string(conversion.xml)
    except (RuntimeError, ValueError, TypeError) as e:
        raise CodermindError(f"{scene.path}: the converted scene does not load: {e}") from None
    attach_emitters(loaded)
    return probe_exposure(loaded, conversion.settings)


def convert_scene(scene, out: str | os.PathLike | None, target: float | None = None,
                  max_depth: int | None = None, spp: int | None = None,
                  blob_max_error: float | None = None, exposure: float | None = None,
                  lights: str | None = None, command: str | None = None,
                  integrator: str = "tutorialpath", quirks: str = "clean") -> Conversion:
    """The conversion of a parsed scene (the model chosen, with the probe pass if needed)."""
    check_finite(scene)     # before the model choice, which computes with the values
    target = DEFAULT_TARGET if target is None else target
    forced_depth = quirks == "strict" and max_depth is None
    if forced_depth:
        # the original's 10 segments: strict adds the cube map at the limit, so a shorter
        # path (the chooser's bound) would add it early
        max_depth = FULL_DEPTH + 1
    kwargs = dict(max_depth=max_depth, spp=spp, blob_max_error=blob_max_error,
                  lights=lights or "sum")
    model = choose(scene, target, exposure=exposure, **kwargs)
    if model.needs_exposure:
        model = choose(scene, target, exposure=estimate_exposure(scene, target), **kwargs)
    if forced_depth:
        model.reasons["max_depth"] = ("the original's 10 segments (strict adds the cube map at "
                                      "the segment limit)")
    if integrator == "tutorialpath":
        model.reasons["lights"] = "the tutorialpath integrator adds every light at every hit"
    return convert(scene, out, model, command, integrator, quirks)


def convert_file(scene, out: str | os.PathLike, **options) -> ConvertResult:
    """Convert a parsed scene and write the XML to ``out`` atomically."""
    conversion = convert_scene(scene, out, **options)
    try:
        with atomic_path(out) as tmp:
            tmp.write_text(conversion.xml, encoding="utf-8")
    except OSError as e:
        raise CodermindError(f"{out}: cannot write: {e.strerror or e}") from None
    return ConvertResult(conversion, list(scene.warnings))
