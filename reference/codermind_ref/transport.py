"""Path tracing of the tutorial programs, vectorized over rays (loops run over segments).

Pages 1 and 2 (:func:`whitted`): shade every hit with the lights, then continue along the
mirror direction with coef *= Reflection, while coef > 0 and fewer than 10 segments; a miss
is black.

Page 4 (:func:`roulette`, facts.md F8): at each hit the Fresnel reflectance R gives
Rf = Reflection R and Tr = Refraction (1 - R) (R = 1 for "metals", Density 0); one uniform u
per segment picks reflect (u <= Rf; coef *= Reflection), refract (u <= Rf + Tr;
coef *= Refraction) or a diffuse event, which outside an object shades with the lights and
ends the path. A miss adds coef * cubemap(d).

Random numbers: ray i uses ``draws[i, 2 + segment]`` for the roulette of segment 0..9 (in
strict mode a re-traced segment counts as a segment), so strict and clean consume the same
numbers and differ only where a quirk acts.

Clean mode as an estimator (what Mitsuba's path tracer reproduces in expectation): with
P_r = min(Rf, 1), P_t = min(Rf + Tr, 1) - P_r, P_d = 1 - min(Rf + Tr, 1), the radiance leaving
a hit toward the eye is

* outside: P_d * Direct + P_r * Reflection * L(reflected) + P_t * Refraction * L(refracted),
  where Direct = sum over unshadowed lights with L.n > 0 of (L.n) I Colour +
  max(n.H, 0)^Power I Specular (shadow rays up to the true light distance);
* inside: (P_r * Reflection * L(reflected) + P_t * Refraction * L(refracted)) / (P_r + P_t),
  0 if Rf + Tr = 0;
* a miss: cubemap(d). After the 10th segment no hit is shaded any more, but the ray leaving
  it is still traced and adds cubemap(d) if it escapes (the fix of the quirk that adds the
  cube map there without tracing). This is what Mitsuba's ``path`` with ``max_depth`` 11
  does: light sampling at the first 10 hits, emission seen by the 11th ray.

Strict mode adds the quirks of :mod:`codermind_ref.quirks`.
"""

from __future__ import annotations

import numpy as np

from .materials import bump
from .quirks import Quirks
from .shading import direct
from .vec import dot
from .world import World

MAX_SEGMENTS = 10
T_START = 2000.0
REFLECT, REFRACT, DIFFUSE = 0, 1, 2


def whitted(world: World, o: np.ndarray, d: np.ndarray, quirks: Quirks) -> np.ndarray:
    """Pages 1 and 2: colour (3, N) of rays o, d."""
    colour = np.zeros_like(o)
    ids = np.arange(o.shape[1])
    coef = np.ones(ids.size)
    mt = world.materials
    for _ in range(MAX_SEGMENTS):
        t, obj = world.intersect(o, d, np.full(ids.size, T_START, dtype=world.dtype))
        p = o + t * d
        n, zero = world.normal(p, np.maximum(obj, 0))
        keep = np.flatnonzero((obj >= 0) & ~zero)
        ids, obj, p, n, d, coef = ids[keep], obj[keep], p[:, keep], n[:, keep], d[:, keep], coef[keep]
        if ids.size == 0:
            break
        mat = world.object_material[obj]
        colour[:, ids] += direct(world, p, n, d, coef, mat, mt.diffuse[:, mat], quirks)
        coef = coef * mt.reflection[mat]
        d = d - (2.0 * dot(d, n)) * n
        o = p
        keep = np.flatnonzero(coef > 0.0)
        ids, o, d, coef = ids[keep], o[:, keep], d[:, keep], coef[keep]
    return colour


def fresnel(n1: np.ndarray, n2: np.ndarray, cos_i: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(R, cosT): normal incidence (cosI >= 0.999) uses ((n1-n2)/(n1+n2))^2 and cosT = 1; total
    internal reflection (sinT^2 > 0.9999) gives R = 1, cosT = 0; else the mean of the s and p
    reflectances."""
    sin_t = (n1 / n2) * np.sqrt(np.maximum(1.0 - cos_i * cos_i, 0.0))
    sin_t2 = sin_t * sin_t
    tir = sin_t2 > 0.9999
    cos_t = np.sqrt(np.maximum(1.0 - sin_t2, 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        rs = (n2 * cos_t - n1 * cos_i) / (n2 * cos_t + n1 * cos_i)
        rp = (n1 * cos_t - n2 * cos_i) / (n1 * cos_t + n2 * cos_i)
        r0 = (n1 - n2) / (n1 + n2)
    r = 0.5 * (rs * rs + rp * rp)
    head_on = cos_i >= 0.999
    r = np.where(head_on, r0 * r0, np.where(tir, 1.0, r))
    cos_t = np.where(head_on, 1.0, np.where(tir, 0.0, cos_t))
    return r, cos_t


def _decide(u: np.ndarray, rf: np.ndarray, tr: np.ndarray) -> np.ndarray:
    # a negative index gives NaN weights: they compare false, a diffuse event, as in C
    with np.errstate(invalid="ignore"):
        some = rf + tr > 0.0
        return np.where(some & (u <= rf), REFLECT,
                        np.where(some & (u <= rf + tr), REFRACT, DIFFUSE)).astype(np.int8)


def refracted(d: np.ndarray, n: np.ndarray, cos_i: np.ndarray, cos_t: np.ndarray,
              ratio: np.ndarray, quirks: Quirks) -> np.ndarray:
    """(n1/n2)(d + cosI n) - cosT n (facts.md F8; n faces the ray): unit by Snell's law, except
    where cosI >= 0.999 forced cosT = 1; ``refraction_length`` keeps that length (the original),
    clean normalizes."""
    out = ratio * (d + cos_i * n) - cos_t * n
    if quirks.refraction_length:
        return out
    return out / np.sqrt(np.maximum(dot(out, out), 1e-300))


def roulette(world: World, o: np.ndarray, d: np.ndarray, draws: np.ndarray,
             quirks: Quirks) -> np.ndarray:
    """Page 4: colour (3, N) of rays o, d; draws (N, 2 + MAX_SEGMENTS) uniforms in [0, 1)."""
    n_rays = o.shape[1]
    colour = np.zeros((3, n_rays))
    env = world.environment
    mt = world.materials
    ids = np.arange(n_rays)
    coef, n1 = np.ones(n_rays), np.ones(n_rays)
    level = np.zeros(n_rays, dtype=np.intp)

    def add_env(sel, directions):
        if sel.size:
            colour[:, ids[sel]] += coef[sel] * env.lookup(directions)

    while ids.size:
        t, obj = world.intersect(o, d, np.full(ids.size, T_START), quirks)
        miss = np.flatnonzero(obj < 0)
        add_env(miss, d[:, miss])
        keep = np.flatnonzero(obj >= 0)
        ids, o, d, t, obj = ids[keep], o[:, keep], d[:, keep], t[keep], obj[keep]
        coef, n1, level = coef[keep], n1[keep], level[keep]
        if ids.size == 0:
            break
        p = o + t * d
        n, zero = world.normal(p, obj)
        if zero.any():  # the path stops; strict still adds the cube map
            if quirks.cubemap_at_limit:
                add_env(np.flatnonzero(zero), d[:, zero])
            keep = np.flatnonzero(~zero)
            ids, o, d, p, n, obj = ids[keep], o[:, keep], d[:, keep], p[:, keep], n[:, keep], obj[keep]
            coef, n1, level = coef[keep], n1[keep], level[keep]
            if ids.size == 0:
                break
        inside = dot(n, d) > 0.0
        n = np.where(inside, -n, n)
        mat = world.object_material[obj]
        level_b = mt.bumplevel[mat]
        bumped = np.flatnonzero(level_b != 0.0)
        if bumped.size:
            n[:, bumped] = bump(n[:, bumped], p[:, bumped], level_b[bumped])

        refl, refr, dens = mt.reflection[mat], mt.refraction[mat], mt.density[mat]
        n2 = np.where(inside, 1.0, dens)
        if not quirks.path_index:
            n1 = np.where(inside, dens, 1.0)
        cos_i = np.abs(dot(d, n))
        fres = ((refl != 0.0) | (refr != 0.0)) & (dens != 0.0)
        r, cos_t = fresnel(n1, np.where(fres, n2, 1.0), cos_i)
        r = np.where(fres, r, 1.0)
        cos_i, cos_t = np.where(fres, cos_i, 1.0), np.where(fres, cos_t, 1.0)
        rf, tr = refl * r, refr * (1.0 - r)

        u = draws[ids, 2 + level]
        if quirks.inside_retrace:
            event = _decide(u, rf, tr)
            again = np.flatnonzero(inside & (event == DIFFUSE))
            while again.size:   # re-trace the same segment: same hit, next segment's draw
                level[again] += 1
                again = again[level[again] < MAX_SEGMENTS]
                event[again] = _decide(draws[ids[again], 2 + level[again]], rf[again], tr[again])
                again = again[event[again] == DIFFUSE]
            stuck = np.flatnonzero(inside & (event == DIFFUSE))  # ran out of segments
            if quirks.cubemap_at_limit:
                add_env(stuck, d[:, stuck])
        else:
            total = rf + tr
            event = _decide(np.where(inside, u * np.minimum(total, 1.0), u), rf, tr)

        shade = np.flatnonzero(~inside & (event == DIFFUSE))
        if shade.size:
            m = mat[shade]
            surface = mt.colour(m, p[:, shade])
            colour[:, ids[shade]] += direct(world, p[:, shade], n[:, shade], d[:, shade],
                                            coef[shade], m, surface, quirks)

        reflect, refract = event == REFLECT, event == REFRACT
        d_reflect = d - (2.0 * dot(d, n)) * n
        ratio = n1 / np.where(refract, n2, 1.0)
        d = np.where(reflect, d_reflect, refracted(d, n, cos_i, cos_t, ratio, quirks))
        coef = coef * np.where(reflect, refl, np.where(refract, refr, 0.0))
        n1 = np.where(refract, n2, n1)
        level = level + 1
        go_on = coef > 0.0
        at_limit = np.flatnonzero(go_on & (level >= MAX_SEGMENTS))
        if quirks.cubemap_at_limit:
            add_env(at_limit, d[:, at_limit])
        elif at_limit.size:     # clean: the last ray is traced; only an escape sees the sky
            _, hit = world.intersect(p[:, at_limit], d[:, at_limit], np.full(at_limit.size, T_START),
                                     quirks)
            escaped = at_limit[hit < 0]
            add_env(escaped, d[:, escaped])
        keep = np.flatnonzero(go_on & (level < MAX_SEGMENTS))
        ids, o, d, coef, n1, level = ids[keep], p[:, keep], d[:, keep], coef[keep], n1[keep], level[keep]
    return colour
