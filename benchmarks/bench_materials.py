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
  gradient; also with an 8-bit table), 5 look-ups with the branchy gradient, and the
  plugin's (5 look-ups of pre-combined tables, arithmetic gradient) with its reference
  gradient, all bit-identical; and the plugin's default, the tutorial's gradient, against
  the same 14-look-up structure with the tutorial's branchy gradient (bit-identical)

    python benchmarks/bench_materials.py [--rounds 7] [--size 384] [--spp 8] [--threads N]
"""

from __future__ import annotations

import argparse
import statistics
import time

import drjit as dr
import mitsuba as mi
import numpy as np


# -- the "before" noise: Perlin's reference, look-up for look-up ------------------------------
def branchy_grad(hash_, x, y, z):
    """Perlin's grad() with its branches as selects."""
    h = hash_ & 15
    u = dr.select(h < 8, x, y)
    v = dr.select(h < 4, y, dr.select((h == 12) | (h == 14), x, z))
    return dr.select((h & 1) == 0, u, -u) + dr.select((h & 2) == 0, v, -v)


def branchy_grad_tutorial(hash_, x, y, z):
    """The tutorial's grad() (spec 2.8) with its branches as selects."""
    h = hash_ & 15
    twelve = (h == 12) | (h == 13)
    u = dr.select((h < 8) | twelve, x, y)
    v = dr.select((h < 4) | twelve, y, z)
    return dr.select((h & 1) == 0, u, -u) + dr.select((h & 2) == 0, v, -v)


def reference_noise(x, y, z, table_type=None, grad=branchy_grad):
    """Perlin's reference structure: 14 look-ups in the 512-entry table (UInt32, or the
    8-bit type given), with the branchy gradient given."""
    from codermind.textures import _noise
    table_type = table_type or mi.UInt32
    p = table_type(np.array(_noise.PERMUTATION * 2, dtype=np.uint32))

    def perm(i):
        return mi.UInt32(dr.gather(table_type, p, i))

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


def packed_noise_branchy(x, y, z):
    """The plugin's 5 look-ups, but with Perlin's branchy gradient on 4-bit hashes."""
    from codermind.textures import _noise
    p = np.array(_noise.PERMUTATION * 2, dtype=np.uint32)
    h = np.arange(511)
    nibbles = mi.UInt32(np.append((p[h] & 15) | ((p[h + 1] & 15) << 4), 0).astype(np.uint32))
    (ix, x, x1, u), (iy, y, y1, v), (iz, z, z1, w) = _noise._cell(x), _noise._cell(y), _noise._cell(z)
    q = dr.gather(mi.UInt32, _noise._PAIRS, (ix << 8) | iy)
    g = [dr.gather(mi.UInt32, nibbles, ((q >> s) & 255) + iz) for s in (0, 8, 16, 24)]
    lerp, grad = _noise._lerp, branchy_grad
    lo = lerp(v, lerp(u, grad(g[0], x, y, z), grad(g[2], x1, y, z)),
              lerp(u, grad(g[1], x, y1, z), grad(g[3], x1, y1, z)))
    hi = lerp(v, lerp(u, grad(g[0] >> 4, x, y, z1), grad(g[2] >> 4, x1, y, z1)),
              lerp(u, grad(g[1] >> 4, x, y1, z1), grad(g[3] >> 4, x1, y1, z1)))
    return lerp(w, lo, hi)


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


def hashed_points(n, scale):
    """n pseudo-random points in [-scale, scale]^3 computed inside the kernel (no memory
    traffic: with stored inputs the benchmark measures memory bandwidth, not the noise)."""
    i = dr.arange(mi.UInt32, n)

    def coordinate(k):
        v = i * 2654435761 + k * 40503
        v = (v ^ (v >> 15)) * 2246822519
        v = v ^ (v >> 13)
        return mi.Float(v & 0xFFFFFF) * (2.0 * scale / 16777216.0) - scale

    return coordinate(1), coordinate(2), coordinate(3)


def bench_noise_core(rounds, n=4_000_000):
    """The noise function alone on n points (no rendering), summed in the kernel."""
    from codermind.textures import _noise
    fns = {"reference structure (14 look-ups)": reference_noise,
           "  same, 8-bit table": lambda x, y, z: reference_noise(x, y, z, dr.llvm.ad.UInt8),
           "5 look-ups, branchy grad": packed_noise_branchy,
           "plugin (5 look-ups, arithmetic grad)":
               lambda x, y, z: _noise.noise(x, y, z, "reference"),
           "tutorial grad, 14 look-ups, branchy":
               lambda x, y, z: reference_noise(x, y, z, grad=branchy_grad_tutorial),
           "plugin default (tutorial grad)": _noise.noise}
    xs = hashed_points(100_000, 60.0)
    ref = reference_noise(*xs).numpy()
    tut = reference_noise(*xs, grad=branchy_grad_tutorial).numpy()
    assert np.abs(ref - tut).max() > 0.1                           # the gradients differ
    for name, f in fns.items():
        expected = tut if "tutorial" in name else ref
        assert np.abs(f(*xs).numpy() - expected).max() == 0, name  # bit-identical
        dr.eval(dr.sum(f(*hashed_points(n, 60.0))))               # compile
    times = {k: [] for k in fns}
    for _ in range(rounds):
        for k, f in fns.items():
            dr.sync_thread()
            t0 = time.perf_counter()
            dr.eval(dr.sum(f(*hashed_points(n, 60.0))))
            dr.sync_thread()
            times[k].append(time.perf_counter() - t0)
    med = {k: statistics.median(t) for k, t in times.items()}
    base = med["reference structure (14 look-ups)"]
    print(f"\nnoise core, {n / 1e6:.0f}M points in [-60, 60]^3 (medians of {rounds})")
    for k, t in med.items():
        print(f"  {k:<40} {t * 1e3:8.2f} ms  {t / base:6.3f}x  {n / t / 1e6:7.1f} Mpoints/s")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--size", type=int, default=384)
    ap.add_argument("--spp", type=int, default=8)
    ap.add_argument("--threads", type=int, help="Dr.Jit worker threads (default: all cores); "
                    "1 is steadier on a machine shared with other work")
    args = ap.parse_args()

    mi.set_variant("llvm_ad_rgb")
    if args.threads:
        dr.set_thread_count(args.threads)
    import codermind  # noqa: F401
    register_reference_perlin()
    s, spp, R = args.size, args.spp, args.rounds
    print(f"llvm_ad_rgb, {dr.thread_count()} threads, {s}x{s}, {spp} spp, {R} interleaved "
          f"rounds; times are medians")

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
        "noisebump, reference gradient": scene({"type": "noisebump", "bumplevel": 0.3,
                                                "gradient": "reference",
                                                "bsdf": {"type": "diffuse"}}, s, spp, 3),
    }, R, "normalmap (built-in)")

    def textured(tex):
        return plane_scene({"type": "diffuse", "reflectance": tex}, s, spp)

    configs = {
        "checkerboard (built-in)": textured({"type": "checkerboard"}),
        "perlin (1 octave)": textured({"type": "perlin", "frequency": 0.05}),
        "perlin, reference gradient": textured({"type": "perlin", "frequency": 0.05,
                                                "gradient": "reference"}),
        "perlin, reference structure (before)": textured({"type": "perlin_reference",
                                                          "frequency": 0.05}),
    }
    for kind in ("turbulence", "marble"):
        for octaves in (1, 3, 9):
            configs[f"{kind} ({octaves} octave{'s' if octaves > 1 else ''})"] = \
                textured({"type": kind, "octaves": octaves})
        configs[f"{kind} (9 octaves), reference gradient"] = \
            textured({"type": kind, "gradient": "reference"})
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
