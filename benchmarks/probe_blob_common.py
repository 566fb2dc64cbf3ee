"""Shared pieces of the probe_blob_*.py diagnostics (page 4's glass blob, port vs Mitsuba):
the scene edits on both sides, the crop's rays, the spec 2.7 glass event in float64, the
segment loops on the port's exact surface and on Mitsuba's mesh, and the per-channel report.

The scripts import it from their own folder (sys.path of __file__'s parent). Mitsuba is
imported only inside the functions that need it (probe_blob_portcrn.py runs without it), after
the script has set its variant."""
import argparse
import re
import os
import tempfile
from types import SimpleNamespace

import numpy as np
from codermind_ref import camera, quirks as Q
from codermind_ref.materials import bump as bump_normal
from codermind_ref.scene import parse_scene
from codermind_ref.transport import fresnel
from codermind_ref.vec import dot
from codermind_ref.world import World

ROOT = os.environ.get("ROOT", os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BLOB = 3  # the blob's object id in the port's world (material3)


def arg_parser(lens, lens_help=None, me=True):
    """The options the probes share: --me (the blob mesh's max_error), --lens (lens draws per
    sub-sample), --rect (the crop) and --seed (the lens draws)."""
    ap = argparse.ArgumentParser()
    if me:
        ap.add_argument("--me", type=float, default=0.086487)
    ap.add_argument("--lens", type=int, default=lens, help=lens_help)
    ap.add_argument("--rect", default="300,250,332,274")
    ap.add_argument("--seed", type=int, default=0)
    return ap


def port_scene(bump=None, refraction=None, lights=True, mirror=True, mirror_bump=None,
               dispersion=None):
    """page4.txt parsed, with the blob's (material3) bumplevel / refraction, the lights, sphere
    1's (material1) reflection and bumplevel and the camera's dispersion changed where given."""
    scene = parse_scene(f"{ROOT}/scenes/page4.txt")
    if dispersion is not None:
        scene.camera.dispersion = dispersion
    if bump is not None:
        scene.materials[3].bumplevel = bump
    if refraction is not None:
        scene.materials[3].refraction = refraction
    if not lights:
        for light in scene.lights:
            light.intensity = (0.0, 0.0, 0.0)
    if not mirror:
        scene.materials[1].reflection = 0.0
    if mirror_bump is not None:
        scene.materials[1].bumplevel = mirror_bump
    return scene


def page4_xml(bump=None, refraction=None, lights=True, mirror=True, mirror_bump=None,
              normals=None, exact_hits=None):
    """page4.xml's text with the same edits as port_scene (and the blob's normals mode, the
    integrator's exact_hits)."""
    xml = open(f"{ROOT}/scenes/page4.xml").read()
    if exact_hits is not None:
        tag = '<integrator type="tutorialpath">'
        assert tag in xml
        xml = re.sub(r'<boolean name="exact_hits" value="\w+"/>', "", xml)
        xml = xml.replace(tag, f'{tag}<boolean name="exact_hits" value="{str(exact_hits).lower()}"/>', 1)
    i = xml.index('id="material3"')
    if bump is not None:
        j = xml.index('bumplevel', i)
        xml = xml[:j] + xml[j:].replace('value="0.1"', f'value="{bump}"', 1)
    if refraction is not None:
        j = xml.index('name="refraction"', i)
        xml = xml[:j] + xml[j:].replace('value="0.9"', f'value="{refraction}"', 1)
    if not lights:
        xml = xml.replace('name="intensity" value="5, 5, 5"', 'name="intensity" value="0, 0, 0"')
        xml = xml.replace('name="intensity" value="0.6, 0.7, 1"', 'name="intensity" value="0, 0, 0"')
    i = xml.index('id="material1"')
    if mirror_bump is not None:
        j = xml.index('bumplevel', i)
        xml = xml[:j] + xml[j:].replace('value="0.1"', f'value="{mirror_bump}"', 1)
    if not mirror:
        j = xml.index('name="reflection"', i)
        xml = xml[:j] + xml[j:].replace('value="1"', 'value="0"', 1)
    if normals is not None:
        xml = xml.replace('name="normals" value="exact"', f'name="normals" value="{normals}"')
    return xml


def load_mitsuba(xml, **params):
    """mi.load_file of the edited XML (through a temporary file beside nothing else)."""
    import mitsuba as mi
    tmp = os.path.join(tempfile.gettempdir(), f"probe_blob_{os.getpid()}.xml")
    open(tmp, "w").write(xml)
    mi.file_resolver().append(f"{ROOT}/scenes")
    try:
        return mi.load_file(tmp, **params)
    finally:
        os.remove(tmp)


def crop_rays(scene, rect, lens, rng, world=None):
    """Camera rays of the crop rect "x0,y0,x1,y1" at half-pixel sub-samples: `lens` lens draws
    per sub-sample from rng (a Generator or a seed), or the pinhole (lens-centre) ray if lens is
    0. With a world, also the labels: the sub-sample's pinhole ray hits the blob. Returns
    (o, d, lab); lab is None without a world."""
    x0, y0, x1, y1 = map(int, rect.split(","))
    sx, sy = np.meshgrid(np.arange(2 * x0, 2 * x1) / 2.0, np.arange(2 * y0, 2 * y1) / 2.0)
    sx, sy = sx.ravel(), sy.ravel()
    k = max(lens, 1)
    lab = None
    if world is not None:
        o0, d0 = camera.rays(scene, sx, sy)
        _, obj0 = world.intersect(o0, d0, np.full(sx.size, 2000.0), Q.CLEAN)
        lab = np.repeat(obj0 == BLOB, k)
    fx, fy = np.repeat(sx, k), np.repeat(sy, k)
    if lens:
        rng = np.random.default_rng(rng)
        o, d = camera.rays(scene, fx, fy, rng.random(fx.size), rng.random(fx.size))
    else:
        o, d = camera.rays(scene, fx, fy)
    return o, d, lab


def glass(d, n, u=None, density=2.0, refraction=0.9, bump=0.0, p=None, inclusive=False):
    """Spec 2.7's glass event in float64 at a blob hit: the side test by the unbumped normal n
    (as noisebump does), the facing normal nf (bumped at p if bump), cos_i, Fresnel R, the
    mirror direction; with draws u also the roulette (reflect with 0.9 R, refract with
    refraction (1 - R), u scaled by their sum inside; `inclusive`: the port's <=), the weight w
    (0 ends the path) and the new direction wo."""
    inside = dot(n, d) > 0
    nf = np.where(inside, -n, n)
    if bump:
        nf = bump_normal(nf, p, np.full(nf.shape[1], bump))
    ci = np.abs(dot(d, nf))
    n1, n2 = np.where(inside, density, 1.0), np.where(inside, 1.0, density)
    R, ct = fresnel(n1, n2, ci)
    g = SimpleNamespace(inside=inside, nf=nf, ci=ci, R=R, mirror=d - 2 * dot(d, nf) * nf)
    if u is None:
        return g
    rf, tr = 0.9 * R, refraction * (1.0 - R)
    uu = np.where(inside, u * np.minimum(rf + tr, 1.0), u)
    if inclusive:
        g.refl = uu <= rf
        g.refr = ~g.refl & (uu <= rf + tr)
    else:
        g.refl = uu < rf
        g.refr = ~g.refl & (uu < rf + tr)
    g.w = np.where(g.refl, 0.9, np.where(g.refr, refraction, 0.0))
    eta = n1 / n2
    dref = eta * (d + ci * nf) - ct * nf
    dref = dref / np.sqrt(dot(dref, dref))
    g.wo = np.where(g.refl, g.mirror, dref)
    return g


def crop_setup(a, **edits):
    """port_scene(**edits), its World and crop_rays of a.rect, a.lens, a.seed with the labels:
    (world, o, d, lab)."""
    scene = port_scene(**edits)
    world = World(scene)
    o, d, lab = crop_rays(scene, a.rect, a.lens, a.seed, world)
    return world, o, d, lab


def trace_port(world, o, d, step, rays=11):
    """Paths on the port's exact surface: a miss adds coef x the cube map, a blob hit calls
    step(seg, ids, d, n, p) -> namespace with inside, w (weight, 0 ends) and wo; any other
    object ends the path; at most `rays` rays. Returns (val (3, N), escape segment, inside
    hits) per ray."""
    env = world.environment
    N = o.shape[1]
    val = np.zeros((3, N)); coef = np.ones(N); ids = np.arange(N)
    segs = np.zeros(N, int); nin = np.zeros(N, int)
    for seg in range(rays):
        t, obj = world.intersect(o, d, np.full(ids.size, 2000.0), Q.CLEAN)
        miss = obj < 0
        val[:, ids[miss]] += coef[miss] * env.lookup(d[:, miss])
        segs[ids[miss]] = seg
        go = obj == BLOB
        if seg == rays - 1:
            break
        ids, o, d, t, coef = ids[go], o[:, go], d[:, go], t[go], coef[go]
        p = o + t * d
        n, _ = world.normal(p, np.full(ids.size, BLOB))
        g = step(seg, ids, d, n, p)
        nin[ids] += g.inside
        coef = coef * g.w
        o, d = p, g.wo
        keep = coef > 0
        ids, o, d, coef = ids[keep], o[:, keep], d[:, keep], coef[keep]
    return val, segs, nin


def arr(v):
    """A Dr.Jit value as numpy, vectors as (3, N)."""
    x = np.array(v)
    return x if x.ndim == 1 or x.shape[0] == 3 else x.T


def mi_float(v):
    import mitsuba as mi
    return mi.Float(np.ascontiguousarray(v, dtype=np.float32))


def mi_vector(v):
    import mitsuba as mi
    return mi.Vector3f(*map(mi_float, v))


def mi_ray(o, d, differential=False):
    """numpy (3, N) origins and directions as a float32 mi.Ray3f (or RayDifferential3f)."""
    import mitsuba as mi
    cls = mi.RayDifferential3f if differential else mi.Ray3f
    return cls(mi.Point3f(*map(mi_float, o)), mi_vector(d))


def trace_mitsuba(ms, env, ray, step, rays=11, exact_hits=False):
    """The same paths on Mitsuba's mesh, with our own directions: scene.ray_intersect from
    `ray`, step(seg, ids, d, n, p) with n the unbumped shading normal at Mitsuba's hit (all N
    lanes, dead ones included), spawn_ray of wo. `exact_hits`: the hits moved by the blob's
    exact_hit, rays leaving from there, and a hit whose crossing lies at the ray's origin
    passed through (Blob.left_surface, along the ray; rays leave exact points without
    Mitsuba's spawn offset, as tutorialpath's exact_hits). Returns (val, escape segment, inside
    hits)."""
    import drjit as dr
    import mitsuba as mi
    from codermind.integrators.tutorialpath import TutorialIntegrator
    blob = [s for s in ms.shapes() if hasattr(s, "exact_hit")][0]
    N = arr(ray.o).shape[1]
    val = np.zeros((3, N)); coef = np.ones(N)
    segs = np.zeros(N, int); nin = np.zeros(N, int)
    alive = np.ones(N, bool); ids = np.arange(N)
    for seg in range(rays):
        si = ms.ray_intersect(ray)
        hit = si
        for _ in range(64 if exact_hits else 0):
            hit = blob.exact_hit(ray, si, si.is_valid() & si.shape.is_mesh())
            behind = si.is_valid() & si.shape.is_mesh() & blob.left_surface(ray, si, hit)
            if not dr.any(behind):
                break
            ray = dr.select(behind, TutorialIntegrator._past(ray, si), ray)
            si = ms.ray_intersect(ray)
        valid = arr(si.is_valid()).astype(bool)
        mesh = arr(si.is_valid() & si.shape.is_mesh()).astype(bool)
        dd = arr(ray.d).astype(np.float64)
        miss = alive & ~valid
        val[:, miss] += coef[miss] * env.lookup(dd[:, miss])
        segs[miss] = seg
        alive = alive & mesh
        if seg == rays - 1 or not alive.any():
            break
        nm = arr(hit.sh_frame.n).astype(np.float64)
        g = step(seg, ids, dd, nm, arr(hit.p).astype(np.float64))
        nin += g.inside & alive
        coef = np.where(alive, coef * g.w, 0.0)
        alive = alive & (coef > 0)
        ray = (mi.Ray3f(hit.p, mi_vector(g.wo)) if exact_hits
               else si.spawn_ray(mi_vector(g.wo)))
    return val, segs, nin


def report_port_mesh(vp, sp, ip, vm, sm, im, lab):
    """Per-channel means of the port's and the mesh's paths on ray subsets, and the share of the
    blob difference by the port's escape segment (probe_blob_det.py, probe_blob_crn.py)."""
    def rep(name, s):
        mp, mm = vp[:, s].mean(1), vm[:, s].mean(1)
        print(f"  {name:28s} n {s.sum():7d} port {mp.round(5)} mesh {mm.round(5)} "
              f"diff {(100*(mm/mp-1)).round(3)} %")
    rep("blob-labelled", lab)
    rep("sky-labelled", ~lab)
    rep("all", np.ones(lab.size, bool))
    for name, s in (("port escapes at seg 1", lab & (sp == 1)), ("port seg >= 2", lab & (sp >= 2)),
                    ("port never escapes", lab & (sp == 0)), ("port inside>=1", lab & (ip > 0)),
                    ("mesh inside>=1", lab & (im > 0))):
        rep(name, s)
    # contribution to the blob difference by the port's segment count at escape
    tot = (vm[:, lab] - vp[:, lab]).sum(1)
    for sg in range(0, 11):
        s = lab & (sp == sg)
        if s.sum():
            c = (vm[:, s] - vp[:, s]).sum(1)
            print(f"   port escape seg {sg:2d}: n {s.sum():7d} share of blob diff {(c/tot).round(3)}  mesh segs same {np.mean(sm[s]==sg):.3f}")
