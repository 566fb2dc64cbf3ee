"""Shadow rays from a point of an analytic blob (the converter's default, ``tessellate``
false) leave the point itself, as the tutorial's do (facts.md F4.2, F7.1): where the zone
field's surface curves back into a ray lit by the gradient normal (facts.md F11.4), the
blob shadows itself."""

from __future__ import annotations

import numpy as np

from support import ROOT

SCENE = ROOT / "scenes" / "user" / "blob-lamp.txt"
#: The left lobe's self-shadow edge from Light0 (tutorial pixels, y up): 12 x 36 pixels.
EDGE = (64, 48, 76, 84)


def test_blob_shadows_itself_where_the_exact_field_says(llvm, tmp_path):
    """Evidence: the port, whose shadow decisions (float64, rays from the point, roots
    beyond 0.01) agree with the tutorial's blob field solved in 50-digit arithmetic
    (codermind_harness.zone_exact) at every sub-sample where the two sides differed; this
    test checks that along a column of the edge. The scene has no randomness, so compare
    holds both sides to the float tolerance: with the shadow ray offset along the normal,
    137 of these 1728 sub-samples were lit on the Mitsuba side and in shadow in the port
    (232 over the whole 160 x 120 frame, 9 now). At most 4 may differ: the float32 limit,
    where L.n is 0.03-0.05 (a float32 hit point a few 1e-4 inside the surface has a chord
    beyond the 0.01 epsilon) or the exact chord only touches the surface (its field peaks
    at 1 - 4e-16); 3 do."""
    import codermind_ref as ref
    from codermind_harness import zone_exact
    from codermind_harness.compare import Options, compare_scene, prepare
    from codermind_ref import camera, quirks, sphere, world
    opt = Options(out_dir=tmp_path, progress=False, rect=EDGE, workers=1)
    rec = compare_scene(prepare(SCENE, opt), opt, "edge")
    failing = rec["z_test"]["failing_sub_samples"]
    assert not rec["random"] and failing <= 4, rec["z_test"]
    # the port's decisions along the edge are the exact field's: every sub-sample of the
    # rect's middle column, each light
    scene = ref.parse_scene(SCENE)
    w = world.World(scene)
    fy = np.arange(EDGE[1], EDGE[3], 0.5)
    fx = np.full(fy.size, 70.0)
    o, d = camera.rays(scene, fx, fy)
    t, obj = w.intersect(o, d, np.full(fy.size, 2000.0), quirks.resolve("clean"))
    on_blob = obj == len(scene.spheres)
    assert on_blob.sum() >= 40
    p = (o + t * d)[:, on_blob]
    blob = scene.blobs[0]
    checked = 0
    for pos in w.light_position:
        to = pos - p
        dist = np.sqrt((to * to).sum(0))
        ldir = to / dist
        blocked = w.occluded(p, ldir, dist, quirks.resolve("clean"))
        for i in range(p.shape[1]):
            th = zone_exact.first_hit(p[:, i], ldir[:, i], np.array(blob.centers), blob.size,
                                      t_min=0.01)
            exact = th is not None and float(th) < dist[i] or any(
                sphere.hit(p[:, i:i + 1], ldir[:, i:i + 1], dist[i:i + 1], c, r)[0] < dist[i]
                for c, r in w.spheres)
            assert bool(blocked[i]) == exact, (i, th, dist[i])
            checked += exact
    assert checked >= 10     # the column crosses the self-shadow
