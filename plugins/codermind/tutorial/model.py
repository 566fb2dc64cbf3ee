"""Model no more than a tutorial scene needs: path depth, samples, blob tessellation.

:func:`choose` decides, from a parsed tutorial scene (``codermind_ref.parse_scene``) and a
pixel-error target in 8-bit levels, the cheapest Mitsuba model whose result differs from the
full model (the tutorial's 10 segments: ``path`` with ``max_depth`` 11) by less than the
target, and says why. ``codermind convert`` runs it and bakes the choice into the XML as
``<default>`` values (override them when rendering with ``-D max_depth=11``; or convert with
``--max-depth``, ``--spp``, ``--blob-max-error``).

**Depth.** Every continuation (mirror reflection or refraction) multiplies the path's
coefficient by the material's ``Reflection`` or ``Refraction``, so after d hits it is at most
w^d, w the largest continuation weight over the materials that can continue (pages 1-2:
``Reflection`` > 0; page 4: ``Reflection`` if reflection can happen -- a metal, or a density
other than 1 --, ``Refraction`` if refraction can happen -- not a metal). What hits d+1 .. 10
and the sky after them add is at most w^d (L_hit sum_{k<10-d} w^k + L_env) per sample and
channel, with L_hit = sum over lights of |I| (max colour + max specular) (Lambert's cosine and
the Blinn lobe are <= 1; a turbulence colour |c1 + T (c0 - c1)| with T <= 1.1 H_9, marble
<= max(|c0|, |c1|)) and L_env the brightest decoded cube-map texel. A radiance error delta
becomes at most: page 1: 255 delta levels; page 2: 255 srgb(1 - exp(-delta)); page 4:
255 srgb(g(E delta)), g(x) = sup_c curve(c + x) - curve(c) (the tone curves and sRGB are
increasing and, except page 4's curve, concave, so an increment is largest at 0). The depth is
the smallest d whose bound is <= the target (d = 10 is the full model). Nothing reflects or
refracts: depth 1 (``max_depth`` 2: light sampling at the first hit, the sky seen by primary
rays). Page 4 needs the exposure E for its bound; the caller supplies it (``codermind
convert`` traces the probe grid through Mitsuba) when the answer depends on it.

**Samples.** A scene is deterministic when neither the lens (``Perspective.Dispersion``) nor
the roulette is random: every material's events are certain (a metal with ``Reflection`` 0 or
1, density 1 -- Fresnel R = 0 -- with ``Refraction`` 0 or 1, or neither reflection nor
refraction). Then one sample per sub-sample is exact. Otherwise the scene's ``Complexity``:
the tutorial tone-maps the mean of Complexity rays per sub-sample, and the tone curve is not
linear, so another count changes the expected image, not only its noise (facts.md F6.2: Complexity
256 is 2.7/255 brighter on average than Complexity 1).

**Blob tessellation.** ``max_error`` = ``BLOB_FRACTION`` of a film pixel's footprint at the
blob's nearest possible distance from the eye (the surface lies within
sqrt(f^-1(1/N)) R of a centre, N the number of sources, f the zone field). At distance t one
tutorial pixel covers t / PD world units, PD = (W/2) / tan(FOV/2), and a sub-sample (a film
pixel of the 2x film) half of that.

**Variant**: ``llvm_ad_rgb``: the tutorial is RGB (no spectral effect), and the Python plugins
are vectorized there.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

#: Full model: the tutorial's 10 segments (light sampling at 10 hits, the 11th ray for the sky).
FULL_DEPTH = 10
#: Default pixel-error target, in 8-bit levels (before truncation).
DEFAULT_TARGET = 0.5
#: Blob max_error as a fraction of a sub-sample's footprint at the blob's nearest distance.
#: A quarter (page 4: 0.0865) left a bias that compare finds: the flat triangles lie inside
#: the surface, so more sky shows at the silhouette (caught at 16 spp) and rays meet the mesh
#: further along, at more grazing incidence, where the Fresnel R rises (+0.36 % of R x cube
#: map on the blob's edge). A sixteenth (0.0216) brings both below the noise of 1024 spp
#: (docs/results/compare.md); the render costs about the same (mesh traversal depends little
#: on the triangle count), only the mesh build grows.
BLOB_FRACTION = 1.0 / 16.0
#: |Perlin improved noise| <= this (about 1.04 is reached); with the 9 octaves' weights 1/k.
NOISE_BOUND = 1.1
TURBULENCE_BOUND = NOISE_BOUND * sum(1.0 / k for k in range(1, 10))
#: The zone field's knots (x = d^2/R^2, f) from x = 10 down to 1 (facts.md F11.1).
ZONE_KNOTS = ((10.0, 0.0), (5.0, 0.2), (10 / 3, 0.3), (2.5, 0.4), (2.0, 0.5), (5 / 3, 0.6),
              (10 / 7, 0.7), (1.25, 0.8), (10 / 9, 0.9), (1.0, 1.0))
VARIANT = "llvm_ad_rgb"


@dataclass
class Model:
    """The chosen model; ``reasons`` explains each choice in one line."""
    max_depth: int                       #: Mitsuba's max_depth (path depth + 1)
    spp: int                             #: samples per film pixel (= per sub-sample)
    stochastic: bool
    blob_max_error: list[float] = field(default_factory=list)
    reasons: dict[str, str] = field(default_factory=dict)
    needs_exposure: bool = False         #: page 4: the depth bound needs E (not given)
    lights: str = "sum"                  #: "sum" (one render per light) or "sample"
    variant: str = VARIANT

    @property
    def depth(self) -> int:
        return self.max_depth - 1

    def summary(self) -> list[str]:
        lines = [f"max_depth {self.max_depth}: {self.reasons['max_depth']}",
                 f"spp {self.spp}: {self.reasons['spp']}"]
        for i, e in enumerate(self.blob_max_error):
            lines.append(f"blob{i}_max_error {e:.4g}: {self.reasons[f'blob{i}']}")
        lines.append(f"lights {self.lights}: {self.reasons['lights']}")
        lines.append(f"variant {self.variant}: {self.reasons['variant']}")
        return lines


# -- what a material can do ----------------------------------------------------------------

def is_metal(m, page: int) -> bool:
    """Page 4's "metal": Fresnel R = 1 (density 0, or neither reflection nor refraction)."""
    return page != 4 or m.density == 0 or (m.reflection == 0 and m.refraction == 0)


def continuation_weight(m, page: int) -> float:
    """The largest factor a continuation at this material multiplies the path by (0: it
    never continues)."""
    if page != 4:
        return m.reflection if m.reflection > 0 else 0.0
    metal = is_metal(m, page)
    can_reflect = m.reflection > 0 and (metal or m.density != 1.0)
    can_refract = m.refraction > 0 and not metal
    return max(m.reflection if can_reflect else 0.0, m.refraction if can_refract else 0.0)


def roulette_is_random(m, page: int) -> bool:
    """Whether the page-4 roulette at this material can go more than one way."""
    if page != 4:
        return False
    if is_metal(m, page):
        return m.reflection not in (0.0, 1.0)
    if m.density == 1.0:              # R = 0: refract with probability Refraction
        return m.refraction not in (0.0, 1.0)
    return True                       # R varies in (0, 1) with the angle


def colour_bound(m, page: int) -> np.ndarray:
    """Per-channel bound of |Diffuse colour| + |Specular| at any point of the material."""
    d, d2 = np.abs(np.array(m.diffuse)), np.abs(np.array(getattr(m, "diffuse2", (0, 0, 0))))
    kind = getattr(m, "type", "gouraud") if page == 4 else "gouraud"
    if kind == "turbulence":
        colour = d2 + TURBULENCE_BOUND * np.abs(np.array(m.diffuse) - np.array(m.diffuse2))
    elif kind == "marble":
        colour = np.maximum(d, d2)
    else:
        colour = d
    specular = np.abs(np.array(m.specular)) if page >= 2 else np.zeros(3)
    return colour + specular


def decoded_cubemap_max(scene) -> np.ndarray:
    """Per-channel maximum cube-map radiance (zero without a cube map)."""
    cm = scene.cubemap
    if scene.page != 4 or not cm.faces:
        return np.zeros(3)
    c = np.max([np.max(face.reshape(-1, 3), axis=0) for face in cm.faces.values()], axis=0)
    c = np.asarray(c, dtype=np.float64)
    if cm.srgb:
        c = np.power(c, 2.2)
    if cm.exposed:
        c = -np.log(1.001 - c)
    return np.abs(c / cm.exposure)


# -- radiance error -> 8-bit levels ---------------------------------------------------------

def _srgb(v: float) -> float:
    return 12.92 * v if v <= 0.0031308 else 1.055 * v ** (1 / 2.4) - 0.055


def _page4_curve(c: np.ndarray, midpoint: float, power: float, black: float) -> np.ndarray:
    if black == 0:
        return -np.expm1(-c)
    n = -math.log1p(-midpoint)
    s = -(1.0 + black / n ** (power - 1.0))
    return 1.0 - np.exp(s * c ** power / (black + c ** (power - 1.0)))


def levels(delta: float, scene, exposure: float | None) -> float:
    """Bound, in 8-bit levels (before truncation), of what a radiance error ``delta`` (per
    sub-sample and channel) changes in a pixel."""
    if delta <= 0:
        return 0.0
    if scene.page == 1:
        return 255.0 * delta
    if scene.page == 2:
        return 255.0 * _srgb(min(-math.expm1(-delta), 1.0))
    x = abs(exposure) * delta
    tm = scene.tonemap
    c = np.concatenate([np.linspace(0.0, 4.0, 40001), np.geomspace(4.0, 1e4, 2001)])
    with np.errstate(over="ignore", invalid="ignore"):
        rise = _page4_curve(c + x, tm.midpoint, tm.power, tm.black) - \
            _page4_curve(c, tm.midpoint, tm.power, tm.black)
    g = float(np.nanmax(rise))
    # the grid step is 1e-4: allow for a peak between grid points (curve' <= 2 Midpoint/n...)
    return 255.0 * _srgb(min(max(g, 0.0) * 1.001 + 1e-6, 1.0))


def remaining_radiance(scene, materials, depth: int, w: float) -> float:
    """Bound of what hits depth+1 .. 10 (and the sky after them) add per sample and channel,
    w the continuation weight, ``materials`` those the objects use."""
    if depth >= FULL_DEPTH or w == 0:
        return 0.0
    colour = np.max([colour_bound(m, scene.page) for m in materials], axis=0) \
        if materials else np.zeros(3)
    hit = sum((np.abs(np.array(light.intensity)) * colour for light in scene.lights),
              np.zeros(3))
    env = decoded_cubemap_max(scene)
    series = sum(w ** k for k in range(FULL_DEPTH - depth))
    return float(np.max(w ** depth * (hit * series + env)))


# -- the choice -----------------------------------------------------------------------------

def _blob_reach(n_sources: int) -> float:
    """sqrt(x) of the largest x = d^2/R^2 where one source's field is >= 1/N."""
    level = 1.0 / n_sources
    for (x0, f0), (x1, f1) in zip(ZONE_KNOTS, ZONE_KNOTS[1:]):
        if f0 <= level <= f1:
            return math.sqrt(x0 + (level - f0) * (x1 - x0) / (f1 - f0))
    return 1.0


def blob_max_errors(scene, fraction: float = BLOB_FRACTION) -> tuple[list[float], list[str]]:
    errors, reasons = [], []
    cam = scene.camera
    for blob in scene.blobs:
        reach = _blob_reach(len(blob.centers)) * blob.size
        if cam.type != "conic":
            errors.append(blob.size / 50.0)
            reasons.append("page 4's orthographic mode hits nothing: R/50")
            continue
        eye = np.array([scene.width / 2.0, scene.height / 2.0, 0.0])
        nearest = min(float(np.linalg.norm(np.array(c) - eye)) for c in blob.centers) - reach
        nearest = max(nearest, 1.0)
        pd = (scene.width / 2.0) / math.tan(math.radians(cam.fov) / 2.0)
        footprint = 0.5 * nearest / pd
        errors.append(fraction * footprint)
        reasons.append(f"{fraction:g} of a sub-sample's footprint ({footprint:.3g} world units) "
                       f"at the blob's nearest possible distance {nearest:.4g} from the eye")
    return errors, reasons


def choose(scene, target: float = DEFAULT_TARGET, exposure: float | None = None,
           max_depth: int | None = None, spp: int | None = None,
           blob_max_error: float | None = None, blob_fraction: float = BLOB_FRACTION,
           lights: str = "sum") -> Model:
    """The cheapest model within ``target`` levels of the full one (see the module doc).
    ``max_depth``, ``spp``, ``blob_max_error``: the user's overrides. ``lights``: how the
    render adds the lights (:mod:`codermind.tutorial.render`): with ``sample`` (Mitsuba picks
    one of N lights per hit) a deterministic scene needs N^2 samples of a jitter-free
    stratified sampler (each light picked equally often at every hit) to be exact."""
    if not target > 0:
        raise ValueError(f"target must be > 0 levels, got {target:g}")
    page = scene.page
    used = sorted({o.material_id for o in list(scene.spheres) + list(scene.blobs)})
    materials = [scene.materials[i] for i in used]
    w = max((continuation_weight(m, page) for m in materials), default=0.0)
    reasons: dict[str, str] = {}
    needs_exposure = False
    conic = page == 4 and scene.camera.type == "conic"
    hits_anything = page < 4 or conic

    if max_depth is not None:
        depth_choice = max_depth
        reasons["max_depth"] = "given by the user"
    elif w == 0 or not hits_anything:
        depth_choice = 2
        reasons["max_depth"] = ("no material reflects or refracts: light sampling at the "
                                "first hit is everything (path depth 1)" if hits_anything else
                                "page 4's orthographic mode hits nothing (path depth 1)")
    elif page == 4 and exposure is None and w >= 1:
        depth_choice = FULL_DEPTH + 1
        reasons["max_depth"] = ("the full model (10 segments): a material continues with "
                                "weight 1, so the path coefficient need not decay")
    elif page == 4 and exposure is None:
        needs_exposure = True
        depth_choice = FULL_DEPTH + 1
        reasons["max_depth"] = "page 4 needs the exposure to bound the truncation error"
    else:
        depth = FULL_DEPTH
        for d in range(1, FULL_DEPTH):
            if levels(remaining_radiance(scene, materials, d, w), scene, exposure) <= target:
                depth = d
                break
        depth_choice = depth + 1
        bound = levels(remaining_radiance(scene, materials, depth, w), scene, exposure)
        if depth == FULL_DEPTH:
            reasons["max_depth"] = (f"the full model (10 segments): with continuation weight "
                                    f"{w:g} the bound after 9 hits is still "
                                    f"{levels(remaining_radiance(scene, materials, 9, w), scene, exposure):.3g} "
                                    f"levels > target {target:g}")
        else:
            reasons["max_depth"] = (f"path depth {depth}: what deeper segments can add is at "
                                    f"most {bound:.3g} levels <= target {target:g} "
                                    f"(continuation weight {w:g})")
        if page == 4:
            reasons["max_depth"] += f", at exposure {exposure:.4g}"

    lens = conic and scene.camera.dispersion != 0
    random = [m.index for m in materials if roulette_is_random(m, page)] if hits_anything else []
    stochastic = lens or bool(random)
    if spp is not None:
        spp_choice = spp
        reasons["spp"] = "given by the user"
    elif not stochastic and lights == "sample" and len(scene.lights) > 1:
        spp_choice = len(scene.lights) ** 2
        reasons["spp"] = (f"nothing is random but Mitsuba's choice of one of the "
                          f"{len(scene.lights)} lights per hit: N^2 stratified samples pick "
                          f"each light equally often at every hit, which is exact")
    elif not stochastic:
        spp_choice = 1
        reasons["spp"] = ("nothing is random (no lens blur, every roulette event certain): "
                          "one sample per sub-sample is exact"
                          + (f"; the scene's Complexity {scene.complexity} adds nothing"
                             if page == 4 and scene.complexity > 1 else ""))
    else:
        why = []
        if lens:
            why.append(f"lens blur (Dispersion {scene.camera.dispersion:g})")
        if random:
            why.append("roulette at Material" + ", Material".join(map(str, random)))
        spp_choice = scene.complexity
        reasons["spp"] = (f"the scene's Complexity: random {' and '.join(why)}; the tone curve "
                          f"is applied to the mean of Complexity rays, so another count "
                          f"changes the expected image")

    errors, blob_reasons = blob_max_errors(scene, blob_fraction)
    if blob_max_error is not None:
        errors = [blob_max_error] * len(errors)
        blob_reasons = ["given by the user"] * len(errors)
    for i, r in enumerate(blob_reasons):
        reasons[f"blob{i}"] = r
    reasons["variant"] = "the tutorial is RGB; the Python plugins are vectorized there"
    reasons["lights"] = ("one render per light, added: the tutorial sums all lights at every "
                         "hit" if lights == "sum" else "Mitsuba samples one light per hit "
                         "(same expectation, more noise)")
    return Model(depth_choice, spp_choice, stochastic, errors, reasons, needs_exposure,
                 lights=lights)
