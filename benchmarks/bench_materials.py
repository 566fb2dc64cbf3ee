"""Render time of the material plugins against their nearest Mitsuba built-ins, side by side
in one run (llvm_ad_rgb). Each scene differs from its partner only in the material or
texture. Every configuration is rendered once first (JIT compilation, reported separately),
then the configurations of a group are timed in interleaved rounds; the table shows
medians and the ratio to the group's built-in.

Groups:
  blinnphong vs roughplastic        path, max_depth 5 (global illumination)
  noisebump vs normalmap            nested diffuse; normalmap reads a 512^2 bitmap
  perlin (1 octave) vs checkerboard diffuse reflectance of a plane filling the frame,
                                    direct light only
  turbulence / marble, 1, 3, 9 octaves vs checkerboard, and their cost per octave
  noise core before/after: Perlin's reference structure (14 table look-ups, branchy
  gradient) vs the plugin's (5 look-ups of pre-combined tables, arithmetic gradient)

    python benchmarks/bench_materials.py [--rounds 7] [--size 384] [--spp 8]
"""

from __future__ import annotations

import argparse
import statistics
import time

import drjit as dr
import mitsuba as mi
import numpy as np


# -- the "before" noise: Perlin's reference, look-up for look-up ------------------------------
def reference_noise(x, y, z):
    from codermind.textures import _noise
    p = mi.UInt32(np.array(_noise.PERMUTATION * 2, dtype=np.uint32))

    def perm(i):
        return dr.gather(mi.UInt32, p, i)

    def grad(hash_, x, y, z):
        h = hash_ & 15
        u = dr.select(h < 8, x, y)
        v = dr.select(h < 4, y, dr.select((h == 12) | (h == 14), x, z))
        return dr.select((h & 1) == 0, u, -u) + dr.select((h & 2) == 0, v, -v)

    fx, fy, fz = dr.floor(x), dr.floor(y), dr.floor(z)
    X, Y, Z = (mi.UInt32(mi.Int32(f) & 255) for f in (fx, fy, fz))
    x, y, z = x - fx, y - fy, z - fz
    u, v, w = _noise._fade(x), _noise._fade(y), _noise._fade(z)
    A = perm(X) + Y
    AA, AB = perm(A) + Z, perm(A + 1) + Z
    B = perm(X + 1) + Y
    BA, BB = perm(B) + Z, perm(B + 1) + Z
    lerp = _noise._lerp
    return lerp(w, lerp(v, lerp(u, grad(perm(AA), x, y, z), grad(perm(BA), x - 1, y, z)),
                        lerp(u, grad(perm(AB), x, y - 1, z), grad(perm(BB), x - 1, y - 1, z))),
                lerp(v, lerp(u, grad(perm(AA + 1), x, y, z - 1), grad(perm(BA + 1), x - 1, y, z - 1)),
                     lerp(u, grad(perm(AB + 1), x, y - 1, z - 1),
                          grad(perm(BB + 1), x - 1, y - 1, z - 1))))


def register_reference_perlin():
    from codermind.textures.perlin import PerlinTexture

    class ReferencePerlin(PerlinTexture):
        def weight(self, p):
            f = self.frequency
            return reference_noise(p.x * f, p.y * f, p.z * f)

    mi.register_texture("perlin_reference", lambda props, cls=ReferencePerlin: cls(props))


# -- scenes ------------------------------------------------------------------------------------
def scene(bsdf: dict, size: int, spp: int, max_depth: int, sphere: bool = True):
    T = mi.ScalarTransform4f
    d = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": max_depth},
        "sensor": {"type": "perspective", "fov": 45,
                   "to_world": T().look_at(origin=[0, 120, -400], target=[0, 0, 0], up=[0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": size, "height": size},
                   "sampler": {"type": "independent", "sample_count": spp}},
        "light": {"type": "point", "position": [150, 300, -200], "intensity": 3e5},
        "floor": {"type": "rectangle", "bsdf": bsdf,
                  "to_world": T().translate([0, -100, 0]).rotate([1, 0, 0], 90).scale(600)},
    }
    if sphere:
        d["ball"] = {"type": "sphere", "radius": 100, "bsdf": bsdf}
    return mi.load_dict(d)


def plane_scene(bsdf: dict, size: int, spp: int):
    """A textured plane filling the whole frame, direct light only: the texture's cost is a
    large share of the render time."""
    T = mi.ScalarTransform4f
    return mi.load_dict({
        "type": "scene",
        "integrator": {"type": "path", "max_depth": 2},
        "sensor": {"type": "perspective", "fov": 60,
                   "to_world": T().look_at(origin=[0, 400, 0], target=[0, 0, 0], up=[0, 0, 1]),
                   "film": {"type": "hdrfilm", "width": size, "height": size},
                   "sampler": {"type": "independent", "sample_count": spp}},
        "light": {"type": "point", "position": [100, 300, 50], "intensity": 3e5},
        "floor": {"type": "rectangle", "bsdf": bsdf,
                  "to_world": T().rotate([1, 0, 0], -90).scale(1000)},
    })


def normal_map(n=512):
    """A bumpy tangent-space normal map (values in [0, 1]) for the built-in normalmap."""
    u, v = np.meshgrid(np.linspace(0, 8 * np.pi, n), np.linspace(0, 8 * np.pi, n))
    nx, ny = 0.3 * np.cos(u) * np.sin(v), 0.3 * np.sin(u) * np.cos(v)
    normal = np.stack([nx, ny, np.ones_like(nx)], -1)
    normal /= np.linalg.norm(normal, axis=-1, keepdims=True)
    return mi.Bitmap((0.5 * normal + 0.5).astype(np.float32))


def render_seconds(sc, seed):
    dr.sync_thread()
    t0 = time.perf_counter()
    image = mi.render(sc, seed=seed)
    dr.eval(image)
    dr.sync_thread()
    return time.perf_counter() - t0


def run_group(title, configs, rounds, baseline):
    """configs: name -> scene. Returns medians (s)."""
    first = {}
    for name, sc in configs.items():
        first[name] = render_seconds(sc, 0)
    times = {name: [] for name in configs}
    for r in range(rounds):
        for name, sc in configs.items():
            times[name].append(render_seconds(sc, r + 1))
    med = {name: statistics.median(t) for name, t in times.items()}
    print(f"\n{title}")
    print(f"  {'configuration':<34} {'median s':>9} {'ratio':>7} {'first call s':>13}")
    for name in configs:
        print(f"  {name:<34} {med[name]:9.4f} {med[name] / med[baseline]:7.3f} {first[name]:13.3f}")
    return med


def bench_noise_core(rounds, n=4_000_000):
    """The noise function alone on n points (no rendering)."""
    from codermind.textures import _noise
    rng = np.random.default_rng(0)
    xs = [mi.Float(rng.uniform(0, 60, n).astype(np.float32)) for _ in range(3)]
    dr.eval(xs)
    fns = {"reference structure (14 look-ups)": reference_noise,
           "plugin (5 look-ups, arithmetic grad)": _noise.noise}
    for f in fns.values():
        dr.eval(f(*xs))
    times = {k: [] for k in fns}
    for _ in range(rounds):
        for k, f in fns.items():
            dr.sync_thread()
            t0 = time.perf_counter()
            dr.eval(f(*xs))
            dr.sync_thread()
            times[k].append(time.perf_counter() - t0)
    med = {k: statistics.median(t) for k, t in times.items()}
    base = med["reference structure (14 look-ups)"]
    print(f"\nnoise core, {n / 1e6:.0f}M points (medians of {rounds})")
    for k, t in med.items():
        print(f"  {k:<40} {t * 1e3:8.2f} ms  {t / base:6.3f}x  {n / t / 1e6:7.1f} Mpts/s")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--size", type=int, default=384)
    ap.add_argument("--spp", type=int, default=8)
    args = ap.parse_args()

    mi.set_variant("llvm_ad_rgb")
    import codermind  # noqa: F401
    register_reference_perlin()
    s, spp, R = args.size, args.spp, args.rounds
    print(f"llvm_ad_rgb, {s}x{s}, {spp} spp, {R} interleaved rounds; times are medians")

    run_group("blinnphong vs roughplastic (path, max_depth 5)", {
        "roughplastic (built-in)": scene({"type": "roughplastic", "alpha": 0.1,
                                          "diffuse_reflectance": {"type": "rgb", "value": [0.5, 0.3, 0.2]}},
                                         s, spp, 5),
        "blinnphong": scene({"type": "blinnphong", "exponent": 200.0, "specular_reflectance": 0.3,
                             "diffuse_reflectance": {"type": "rgb", "value": [0.5, 0.3, 0.2]}},
                            s, spp, 5),
    }, R, "roughplastic (built-in)")

    bitmap = normal_map()
    run_group("noisebump vs normalmap (nested diffuse, path, max_depth 3)", {
        "normalmap (built-in)": scene({"type": "normalmap", "normalmap": {
            "type": "bitmap", "bitmap": bitmap, "raw": True}, "bsdf": {"type": "diffuse"}},
            s, spp, 3),
        "noisebump": scene({"type": "noisebump", "bumplevel": 0.3, "bsdf": {"type": "diffuse"}},
                           s, spp, 3),
    }, R, "normalmap (built-in)")

    def textured(tex):
        return plane_scene({"type": "diffuse", "reflectance": tex}, s, spp)

    configs = {
        "checkerboard (built-in)": textured({"type": "checkerboard"}),
        "perlin (1 octave)": textured({"type": "perlin", "frequency": 0.05}),
        "perlin, reference structure (before)": textured({"type": "perlin_reference",
                                                          "frequency": 0.05}),
    }
    for kind in ("turbulence", "marble"):
        for octaves in (1, 3, 9):
            configs[f"{kind} ({octaves} octave{'s' if octaves > 1 else ''})"] = \
                textured({"type": kind, "octaves": octaves})
    med = run_group("solid textures (diffuse reflectance of a plane filling the frame, direct "
                    "light only)", configs, R,
                    "checkerboard (built-in)")
    base = med["checkerboard (built-in)"]
    for kind in ("turbulence", "marble"):
        per = (med[f"{kind} (9 octaves)"] - med[f"{kind} (1 octave)"]) / 8
        print(f"  {kind}: {per * 1e3:.2f} ms per additional octave = {per / base:.3f} "
              f"checkerboard renders")

    bench_noise_core(R)


if __name__ == "__main__":
    main()
