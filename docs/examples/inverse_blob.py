"""Inverse rendering with the plugins (issue 15, a first version): recover the three
centres of a ``blob`` and the ``color0`` of its ``marble`` texture from a target image,
with Mitsuba's ``prb_projective`` (silhouettes included) and Adam.

    python docs/examples/inverse_blob.py [--iterations 150]

Prints the loss, its fall since the first iteration, the largest centre error in units
of the radius and the colour. Each iteration re-tessellates the blob (the centres move).
"""

from __future__ import annotations

import argparse
import time

import numpy as np

R = 0.8
TRUE_CENTERS = np.array([[-0.7, 0.0, 0.0], [0.7, 0.1, 0.0], [0.0, 0.8, -0.2]])
TRUE_COLOR = [0.8, 0.3, 0.2]
START_CENTERS = TRUE_CENTERS + np.array([[0.15, -0.1, 0.05], [-0.1, 0.12, 0.0],
                                         [0.1, -0.1, 0.1]])
START_COLOR = [0.4, 0.6, 0.6]


def scene_dict(mi, centers: np.ndarray, color, size: int = 48) -> dict:
    return {
        "type": "scene",
        "integrator": {"type": "prb_projective", "max_depth": 2, "sppi": 0},
        "sensor": {"type": "perspective", "fov": 45,
                   "to_world": mi.ScalarTransform4f().look_at([0, 0.5, 5], [0, 0.3, 0],
                                                              [0, 1, 0]),
                   "film": {"type": "hdrfilm", "width": size, "height": size,
                            "rfilter": {"type": "gaussian"}, "sample_border": True}},
        "blob": {"type": "blob", "centers": " ".join(map(str, np.ravel(centers))),
                 "radius": R, "max_error": R / 100, "normals": "flat",
                 "bsdf": {"type": "diffuse", "reflectance": {
                     "type": "marble", "frequency": 1.0, "octaves": 2,
                     "color0": {"type": "rgb", "value": color},
                     "color1": {"type": "rgb", "value": [0.1, 0.1, 0.1]}}}},
        "light": {"type": "point", "position": [2, 3, 4], "intensity": 30.0},
        "env": {"type": "constant", "radiance": 0.2},
    }


def optimise(iterations: int, spp: int = 8, lr: float = 0.02, log=print) -> dict:
    import drjit as dr
    import mitsuba as mi
    mi.set_variant("llvm_ad_rgb")
    import codermind  # noqa: F401  (registers the plugins)

    target = mi.render(mi.load_dict(scene_dict(mi, TRUE_CENTERS, TRUE_COLOR)), spp=64, seed=0)
    scene = mi.load_dict(scene_dict(mi, START_CENTERS, START_COLOR))
    params = mi.traverse(scene)
    keys = ("blob.centers", "blob.bsdf.reflectance.color0.value")
    opt = mi.ad.Adam(lr=lr)
    for key in keys:
        opt[key] = params[key]
    params.update(opt)
    losses, t0 = [], time.perf_counter()
    for it in range(iterations):
        image = mi.render(scene, params, spp=spp, seed=it, seed_grad=iterations + it)
        loss = dr.mean(dr.square(image - target), axis=None)
        dr.backward(loss)
        opt.step()
        params.update(opt)
        losses.append(float(np.ravel(np.array(loss))[0]))
        centers = np.array(params[keys[0]], dtype=np.float64).reshape(-1, 3)
        error = float(np.abs(centers - TRUE_CENTERS).max() / R)
        if it % 10 == 0 or it == iterations - 1:
            log(f"{it:4d}  loss {losses[-1]:.3g}  fall {losses[0] / losses[-1]:7.1f}x  "
                f"centre error {error:.4f} R  colour "
                f"{np.round(np.ravel(np.array(params[keys[1]])), 3).tolist()}  "
                f"{time.perf_counter() - t0:.0f} s")
    return {"losses": losses, "centre_error_over_r": error,
            "color": np.ravel(np.array(params[keys[1]])).tolist()}


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--iterations", type=int, default=150)
    p.add_argument("--spp", type=int, default=8)
    args = p.parse_args()
    optimise(args.iterations, args.spp)


if __name__ == "__main__":
    main()
