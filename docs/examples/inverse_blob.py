"""Inverse rendering with the plugins: recover the three centres of a ``blob``
(the tutorial's zone field, as on page 4) and the ``color0`` of its ``marble`` texture from
a target image, with Mitsuba's ``prb_projective`` (silhouette gradients included) and Adam.

    python docs/examples/inverse_blob.py            # the full run, 150 iterations
    python docs/examples/inverse_blob.py --quick    # 30 iterations, held to 17 (the test)

The target is rendered from the true parameters with the same plugins and the same
sample pattern (seed) as every primal render of the optimisation ("common random
numbers"): the loss is then exactly 0 at the truth, and its fall measures how close the
parameters came, not the Monte Carlo noise. The gradients (the adjoint pass,
``seed_grad``) use a new seed every iteration. Prints the loss, its fall since the first
iteration, the largest centre error in units of the radius R and the colour; at the end one
line ``RESULT loss_fall=... centre_error_over_r=... colour_error=...``.

The schedule: the first ``colour_first`` iterations optimise the colour alone (the centres
are not in the optimiser yet, so the blob is not re-tessellated); with the colour far off,
the centres' gradients pointed partly the wrong way. Then Adam (beta_1 0.6, beta_2 0.9: a
short memory, so the steps do not shrink with the gradients as the loss falls) at full
rate until iteration ``hold``, then both rates fall exponentially to ``final_lr`` times
their start at the last iteration.

Each iteration that moves the centres re-tessellates the blob; the vertex positions and
normals carry the derivative of the surface (the blob's default ``exact`` normals: with
``flat`` ones the facet edges' sweep over the image is not differentiated). The views'
losses are summed and differentiated in one backward pass, which consumes the graph from
the centres to the mesh.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

R = 0.8
TRUE_CENTERS = np.array([[-0.7, 0.0, 0.0], [0.7, 0.1, 0.0], [0.0, 0.8, -0.2]])
TRUE_COLOR = [0.8, 0.3, 0.2]
START_CENTERS = TRUE_CENTERS + np.array([[0.15, -0.1, 0.05], [-0.1, 0.12, 0.0],
                                         [0.1, -0.1, 0.1]])
START_COLOR = [0.4, 0.6, 0.6]
QUICK_ITERATIONS = 30     # the test's run (--quick) ...
QUICK_HOLD = 17           # ... holds the rates 2 iterations longer than the full run's 15


#: Camera positions, all looking at (0, 0.3, 0): the front view (page 4's), then from the
#: side and from above. One view leaves the depth of each centre nearly unobserved (only
#: the shading sees it); each further view sees it in a silhouette.
EYES = ([0, 0.5, 5], [5, 0.8, 0.5], [0.5, 5, 1.5])


def scene_dict(mi, centers: np.ndarray, color, size: int = 48, normals: str = "exact",
               integrator: str = "prb_projective", max_error: float = R / 500,
               views: int = 3) -> dict:
    integ = {"type": integrator, "max_depth": 2}
    if integrator == "prb_projective":
        integ["sppi"] = 0          # no guiding grid: boundary samples drawn uniformly
    d = {"type": "scene", "integrator": integ}
    for i, eye in enumerate(EYES[:views]):
        up = [0, 0, -1] if eye[1] > 4 else [0, 1, 0]
        d[f"sensor{i}"] = {
            "type": "perspective", "fov": 45,
            "to_world": mi.ScalarTransform4f().look_at(eye, [0, 0.3, 0], up),
            "film": {"type": "hdrfilm", "width": size, "height": size,
                     "rfilter": {"type": "gaussian"}, "sample_border": True}}
    return {
        **d,
        "blob": {"type": "blob", "centers": " ".join(map(str, np.ravel(centers))),
                 "radius": R, "max_error": max_error, "normals": normals,
                 "bsdf": {"type": "diffuse", "reflectance": {
                     "type": "marble", "frequency": 1.0, "octaves": 2,
                     "color0": {"type": "rgb", "value": color},
                     "color1": {"type": "rgb", "value": [0.1, 0.1, 0.1]}}}},
        # the point light sits at the front camera: Mitsuba's projective integrators
        # estimate no derivative of a point light's shadow edges (nor does prb), and
        # shadows seen in the image bias the centres' gradients (the gradient table's
        # blob rows with shadows: docs/results/gradients.md). From the front no shadow
        # is visible.
        "light": {"type": "point", "position": EYES[0], "intensity": 30.0},
        # no environment light: its occlusion (shadow rays towards the sky) has no
        # derivative here either; with a constant one (0.2) the centres stalled at 1.35% R
    }


def optimise(iterations: int = 150, size: int = 32, spp: int = 8, lr_centers: float = 0.03,
             lr_color: float = 0.1, final_lr: float = 0.05, normals: str = "exact",
             integrator: str = "prb_projective", views: int = 3, colour_first: int = 4,
             hold: int = 15, beta_1: float = 0.6, beta_2: float = 0.9, grad_seed: int = 0,
             log=print) -> dict:
    """Adam on the colour alone for the first ``colour_first`` iterations, then on the
    centres too; both learning rates stay at their start until iteration ``hold`` and then
    fall exponentially to ``final_lr`` times their start at the last iteration. Returns the
    losses, the final centre error over R and the colour. ``grad_seed`` shifts the seeds of
    the adjoint passes (another sequence of gradient samples; the primal seeds stay)."""
    import drjit as dr
    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")
    import codermind  # noqa: F401  (registers the plugins)

    # The adjoint pass scatters into the vertex positions' gradient. On the LLVM backend
    # Dr.Jit by default reduces arrays that small through per-thread copies whose size is
    # written into the kernel: the mesh's vertex count changes every iteration, so each
    # iteration compiled a new kernel (5-9 s each). Atomic reductions keep one kernel.
    threshold = dr.expand_threshold()
    dr.set_expand_threshold(0)
    try:
        return _optimise(mi, dr, iterations, size, spp, lr_centers, lr_color, final_lr,
                         normals, integrator, views, colour_first, hold, beta_1, beta_2, grad_seed,
                         log)
    finally:
        dr.set_expand_threshold(threshold)


def _optimise(mi, dr, iterations, size, spp, lr_centers, lr_color, final_lr, normals,
              integrator, views, colour_first, hold, beta_1, beta_2, grad_seed, log) -> dict:
    def load(centers, color):
        return mi.load_dict(scene_dict(mi, centers, color, size, normals, integrator,
                                    views=views))

    seed = 0
    truth = load(TRUE_CENTERS, TRUE_COLOR)
    targets = [mi.render(truth, sensor=v, spp=spp, seed=seed + v) for v in range(views)]
    scene = load(START_CENTERS, START_COLOR)
    params = mi.traverse(scene)
    keys = ("blob.centers", "blob.bsdf.reflectance.color0.value")
    rates = {keys[0]: lr_centers, keys[1]: lr_color}
    opt = mi.ad.Adam(lr=lr_centers, beta_1=beta_1, beta_2=beta_2)

    def add(key):        # (Adam's moments of a parameter start when it is added)
        opt[key] = params[key]
        opt.set_learning_rate({key: rates[key]})

    add(keys[1])
    if colour_first <= 0:
        add(keys[0])
    params.update(opt)
    losses, t0 = [], time.perf_counter()
    hold = min(max(hold, 0), iterations - 1)
    decay = final_lr ** (1.0 / max(iterations - 1 - hold, 1))
    error = math.inf
    for it in range(iterations):
        # one backward pass for all views: a pass consumes the graph from the centres to
        # the mesh's buffers, so a second one would reach only the colour
        loss = 0
        for v in range(views):
            image = mi.render(scene, params, sensor=v, spp=spp, seed=seed + v,
                              seed_grad=grad_seed + views * (1 + it) + v)
            loss = loss + dr.mean(dr.square(image - targets[v]), axis=None) / views
        dr.backward(loss)
        losses.append(float(np.ravel(np.array(loss))[0]))
        centers = np.array(params[keys[0]], dtype=np.float64).reshape(-1, 3)
        error = float(np.abs(centers - TRUE_CENTERS).max() / R)   # of the rendered state
        color = np.ravel(np.array(params[keys[1]])).tolist()
        if it % 10 == 0 or it == iterations - 1:
            log(f"{it:4d}  loss {losses[-1]:.3g}  fall {losses[0] / max(losses[-1], 1e-30):8.1f}x"
                f"  centre error {error:.4f} R (x y z: "
                f"{np.round(np.abs(centers - TRUE_CENTERS).max(0) / R, 4).tolist()})  colour {np.round(color, 3).tolist()}  "
                f"{time.perf_counter() - t0:.0f} s")
        if it < iterations - 1:
            opt.step()
            if it + 1 == colour_first:
                add(keys[0])
            for key in keys:
                if key in opt:
                    opt.set_learning_rate({key: rates[key] * decay ** max(it + 1 - hold, 0)})
            params.update(opt)
    fall = losses[0] / max(losses[-1], 1e-30)
    color_error = float(np.abs(np.array(color) - TRUE_COLOR).max())
    log(f"RESULT loss_fall={fall:.4g} centre_error_over_r={error:.5f} "
        f"colour_error={color_error:.5f} colour={np.round(color, 4).tolist()} "
        f"iterations={iterations} size={size} spp={spp} views={views} "
        f"seconds={time.perf_counter() - t0:.0f}")
    return {"losses": losses, "loss_fall": fall, "centre_error_over_r": error,
            "color": color, "color_error": color_error}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true",
                   help="the test's settings: 30 iterations (instead of 150), the rates "
                        "held until iteration 17 (instead of 15)")
    p.add_argument("--iterations", type=int)
    p.add_argument("--size", type=int)
    p.add_argument("--spp", type=int, default=8)
    p.add_argument("--lr-centers", type=float, default=0.03)
    p.add_argument("--lr-color", type=float, default=0.1)
    p.add_argument("--final-lr", type=float, default=0.05,
                   help="learning rates at the end, as a fraction of their start")
    p.add_argument("--colour-first", type=int, default=4,
                   help="iterations on the colour alone before the centres join")
    p.add_argument("--hold", type=int,
                   help="the rates stay at their start until this iteration, then decay "
                        "(default 15; --quick: 17)")
    p.add_argument("--beta-1", type=float, default=0.6)
    p.add_argument("--beta-2", type=float, default=0.9)
    p.add_argument("--grad-seed", type=int, default=0,
                   help="offset of the adjoint passes' seeds (the primal seeds stay)")
    p.add_argument("--normals", default="exact", choices=["exact", "field", "flat"])
    p.add_argument("--integrator", default="prb_projective")
    p.add_argument("--views", type=int, default=3, choices=[1, 2, 3])
    a = p.parse_args()
    iterations = a.iterations or (QUICK_ITERATIONS if a.quick else 150)
    size = a.size or 32
    hold = a.hold if a.hold is not None else (QUICK_HOLD if a.quick else 15)
    optimise(iterations, size, a.spp, a.lr_centers, a.lr_color, a.final_lr, a.normals,
             a.integrator, a.views, a.colour_first, hold, a.beta_1, a.beta_2, a.grad_seed)


if __name__ == "__main__":
    main()
