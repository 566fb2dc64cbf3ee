"""Sweeps of the port's tone pipeline (``codermind_ref.tonemap``, ``driver``): the tone curve
at zero, tiny, huge and non-finite radiance, and the auto exposure on images whose probes are
black.

What a user gets for each input is recorded (curve value and final byte); the checks are that
it is defined: 0 maps to black, every finite radiance to a value in [0, 1], +inf to white, and
a NaN (which can only come from the scene's own numbers, e.g. ``Intensity = nan``) is not
turned silently into a plausible pixel: the render says so.
"""

from __future__ import annotations

import math
import os
import tempfile
from pathlib import Path

import numpy as np

import codermind_ref as ref
from codermind_ref import tonemap
from codermind_ref.scene import Tonemap

from .sweep_result import Plan, Series, SweepResult

SETS = {                        # (Midpoint, Power, Black)
    "default 0.6/3/0.1": (0.6, 3.0, 0.1),
    "page 4 0.7/3/0.1": (0.7, 3.0, 0.1),
    "black 0": (0.6, 3.0, 0.0),
    "power 2": (0.6, 2.0, 0.1),
    "power 10": (0.6, 10.0, 0.1),
    "midpoint 0.01": (0.01, 3.0, 0.1),
    "midpoint 0.99": (0.99, 3.0, 0.1),
}
#: The brightest byte of pages 2 and 4: sRGB(1) = 1.055 - 0.055 = 0.9999999999999999 in
#: float64, and 254.99999999999997 truncates to 254.
WHITE = 254
PLOT_C = np.geomspace(1e-3, 1e3, 200)     # the figure: where the curves differ
SPECIAL = {"0": 0.0, "-0": -0.0, "1e-300": 1e-300, "1e-30": 1e-30, "1": 1.0, "1e30": 1e30,
           "1e200": 1e200, "1.8e308": 1.7976931348623157e308, "inf": math.inf, "nan": math.nan}


def _bytes(v):
    with np.errstate(invalid="ignore", over="ignore"):
        return tonemap.to_bytes(tonemap.srgb(np.asarray(v, dtype=np.float64)))


def _page4_scene(folder: Path, light: str, objects: str = "", name: str = "s.txt",
                 size: str = "24", extra: str = "", version: str = "1.3") -> Path:
    """A tiny scene: a lit grey sphere filling the view (or ``objects``)."""
    objects = objects or ("Material0 { Diffuse = 0.5; }\n"
                          "Sphere0 { Center = 12, 12, 60; Size = 40; Material.Id = 0; }\n")
    camera = ("Perspective.Type = conic;\nPerspective.FOV = 60;\n" if version == "1.3" else "")
    path = folder / name
    major, minor = version.split(".")
    path.write_text(f"Scene {{\nVersion.Major = {major};\nVersion.Minor = {minor};\n"
                    f"Image.Width = {size};\nImage.Height = {size};\n{camera}"
                    f"NumberOfMaterials = {1 if 'Material0' in objects else 0};\n"
                    f"NumberOfSpheres = {objects.count('Sphere')};\n"
                    f"NumberOfLights = {1 if light else 0};\n{extra}}}\n{objects}"
                    + (f"Light0 {{ Position = 12, 12, -100; Intensity = {light}; }}\n"
                       if light else ""))
    return path


def _here(warnings: list[str], folder: str) -> list[str]:
    """The warnings without the temporary folder's name (which differs in every run and
    process): the scene's file name alone."""
    return [w.replace(str(Path(folder)) + os.sep, "") for w in warnings]


def _first_white(tm) -> float | None:
    """The smallest exposed radiance whose byte is the brightest (bisection on log c)."""
    lo, hi = -30.0, 308.0
    if _bytes(tonemap.curve(np.array([10.0 ** hi]), tm))[0] != WHITE:
        return None
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if _bytes(tonemap.curve(np.array([10.0 ** mid]), tm))[0] == WHITE:
            hi = mid
        else:
            lo = mid
    return 10.0 ** hi


RENDERS = (("1.3", "nan"), ("1.1", "nan"), ("1.3", "inf"), ("1.1", "inf"), ("1.3", "1e200"))


def _tone_point(p: tuple) -> dict:
    """("setting", label, quick): one tone-map setting over the radiance sweep;
    ("render", version, light): a tiny scene whose light is ``light``, its lit bytes and the
    render's new warnings."""
    if p[0] == "render":
        _, version, light = p
        with tempfile.TemporaryDirectory() as tmp:
            # the parser refuses a light that is not finite in float32 (codermind_ref.checks):
            # the scene is parsed with a finite one, then given the swept value
            scene = ref.parse_scene(_page4_scene(Path(tmp), "1", version=version))
            value = float(light)
            scene.lights[0].intensity = (value, value, value)
            with np.errstate(all="ignore"):
                result = ref.render(scene, "clean", exposure=1.0)
        return {"lit": result.rgb8[4:12, 8:16],
                "new": _here(result.warnings[len(scene.warnings):], tmp)}
    _, label, quick = p
    c = np.concatenate([[0.0], 10.0 ** np.arange(-30, 309, 4 if quick else 1)])
    tm = Tonemap(*SETS[label])
    out = tonemap.curve(c, tm)
    bad = ~np.isfinite(out)
    special = tonemap.curve(np.array(list(SPECIAL.values())), tm)
    return {"out": out, "nan_from": float(c[bad][0]) if bad.any() else None,
            "saturate": _first_white(tm), "plot": list(tonemap.curve(PLOT_C, tm)),
            "special": special, "special_bytes": _bytes(special), "c": c}


def tone_curve(quick: bool = False) -> Plan:
    """Points: each tone-map setting, each render of a non-finite or huge light."""
    points = [("setting", label, quick) for label in SETS] + [("render",) + v for v in RENDERS]
    return Plan(points, _tone_point, _tone_assemble)


def _tone_assemble(results: list[dict]) -> SweepResult:
    r = SweepResult("tone_curve", "port tone curve vs radiance",
                    parameter="exposed radiance c = 0, 1e-30 to 1e308, inf, nan; 7 tone-map "
                              "settings and page 2's 1 - exp(-c)",
                    measured="curve value and final byte (tonemap.curve, srgb, to_bytes)",
                    threshold="", threshold_value=None, xlabel="exposed radiance c (the sweep runs to 1e308)",
                    ylabel="curve value (1 = white)", ylog=False)
    nan_from, saturate, table = {}, {}, []
    for label, x in zip(SETS, results):
        out, special, c = x["out"], x["special"], x["c"]
        nan_from[label] = x["nan_from"]
        saturate[label] = x["saturate"]
        r.series.append(Series(label, list(PLOT_C), x["plot"], "-"))
        row = {"setting": label}
        for (name, _), value, byte in zip(SPECIAL.items(), special, x["special_bytes"]):
            row[name] = f"{value:.6g} -> {int(byte)}"
        table.append(row)
        finite = np.isfinite(out[c >= 0])
        r.check(f"{label}: finite c >= 0 gives a value in [0, 1], non-decreasing",
                finite.all() and out.min() >= 0 and out.max() <= 1 and np.all(np.diff(out) >= 0),
                f"non-finite from c = {nan_from[label]:.3g}" if nan_from[label] else
                f"range [{np.nanmin(out):.3g}, {np.nanmax(out):.3g}]")
        r.check(f"{label}: c = 0 and -0 give 0 (byte 0), +inf gives 1 (byte {WHITE})",
                special[0] == 0 and special[1] == 0 and special[8] == 1 and
                _bytes(special[8]) == WHITE, f"0 -> {special[0]:.3g}, inf -> {special[8]:.3g}")
    r.series.append(Series("page 2: 1 - exp(-c)", list(PLOT_C), list(1.0 - np.exp(-PLOT_C)),
                           "--", "k"))
    r.table = table
    r.notes.append("curve value -> byte for the special inputs, per setting: " + "; ".join(
        f"{row['setting']}: " + ", ".join(f"{k} {v}" for k, v in row.items() if k != "setting")
        for row in table[:1]))
    # A NaN radiance must not become a plausible pixel silently: render scenes whose light is
    # nan (and inf, 1e200) with a fixed exposure and look at bytes and warnings.
    for (version, light), x in zip(RENDERS, results[len(SETS):]):
        lit, new = x["lit"], x["new"]
        said = any("non-finite" in w for w in new)
        page = 4 if version == "1.3" else 2
        r.notes.append(f"page {page}, Intensity = {light}: lit pixels show bytes "
                       f"{sorted(set(lit.ravel().tolist()))[:6]}; render warnings: "
                       f"{new if new else 'none'}")
        if light == "nan":
            r.check(f"page {page}: a NaN radiance does not pass silently (the render warns)",
                    said, f"bytes {sorted(set(lit.ravel().tolist()))[:4]}, warnings {new}")
        elif light == "inf":     # inf x 0 (the unlit colour channels) is NaN
            r.check(f"page {page}: Intensity = inf renders white ({WHITE}) or warns",
                    bool((lit == WHITE).all()) or said,
                    f"bytes {sorted(set(lit.ravel().tolist()))[:4]}, warned: {said}")
        else:
            r.check(f"page {page}: Intensity = {light} renders white ({WHITE})",
                    bool((lit == WHITE).all()), f"bytes {sorted(set(lit.ravel().tolist()))[:4]}")
    broken = {k: v for k, v in nan_from.items() if v is not None}
    r.threshold = ((("curve non-finite from c = " + ", ".join(
        f"{v:.2g} ({k})" for k, v in broken.items()) + "; ") if broken else
        "curve finite for every finite c >= 0; ") + f"byte {WHITE} (white) from c = " + ", ".join(
        f"{v:.3g} ({k})" for k, v in saturate.items() if v is not None))
    r.threshold_value = min(broken.values()) if broken else None
    return r


RADII = [0.0, 0.5, 1.0, 2.0, 2.5, 3.0, 4.0, 6.0, 8.0, 12.0, 20.0]
RADII_QUICK = [0.0, 1.0, 4.0, 20.0]


def _exposure_point(radius: float) -> dict:
    """A lit sphere of ``radius`` centred between four probe rays: E, its bytes, warnings."""
    with tempfile.TemporaryDirectory() as tmp:
        # the 64 x 64 image's probes sit at multiples of 4 pixels; the sphere is centred at
        # (34, 34) on the image plane (between probes), at the projection distance
        pd = 32 / math.tan(math.radians(30))
        objects = ("Material0 { Diffuse = 0.8; }\n" if radius == 0 else
                   f"Material0 {{ Diffuse = 0.8; }}\nSphere0 {{ Center = 34, 34, {pd}; "
                   f"Size = {radius}; Material.Id = 0; }}\n")
        scene = ref.parse_scene(_page4_scene(Path(tmp), "1", objects, size="64"))
        result = ref.render(scene, "clean", seed=1)
    sphere = result.rgb8[28:30, 33:35]              # display rows: y = 34..35
    return {"row": {"radius": radius, "exposure": result.exposure,
                    "sphere_bytes": sorted(set(sphere.ravel().tolist())),
                    "warnings": _here(result.warnings[len(scene.warnings):], tmp)},
            "mean": float(sphere.mean()) / 255,
            "image": result.rgb8[12:56, 12:56] / 255.0 if radius == 2.0 else None}


def auto_exposure(quick: bool = False) -> Plan:
    """facts.md F6.3: E = -ln(1 - Midpoint) / M with M the RMS luminance of 16 x 16 probe rays,
    and E = -1 if M = 0. A lit sphere shrinks until no probe hits it: then E = -1.
    Points: each radius."""
    radii = RADII_QUICK if quick else RADII
    return Plan(list(radii), _exposure_point, lambda results: _exposure(radii, results))


def _exposure(radii: list[float], results: list[dict]) -> SweepResult:
    r = SweepResult("auto_exposure", "port auto exposure vs a shrinking lit sphere",
                    parameter="radius of the only lit object (a sphere centred between four "
                              "probe rays, 64x64 image, probes every 4 pixels)",
                    measured="auto exposure E, sphere pixels' bytes, render warnings",
                    threshold="", threshold_value=None, xlabel="sphere radius (pixels at its "
                    "depth)", ylabel="E; mean byte of the sphere / 255", xlog=False, ylog=False)
    rows = [x["row"] for x in results]
    exposures = [row["exposure"] for row in rows]
    means = [x["mean"] for x in results]
    image = next((x["image"] for x in results if x["image"] is not None), None)
    r.series = [Series("E", radii, exposures), Series("mean sphere byte / 255", radii, means, "s--")]
    r.table = rows
    black = [row for row in rows if row["exposure"] == -1.0]
    missed = [row for row in black if row["radius"] > 0]
    r.check("an all-black probe set gives E = -1 (facts.md F6.3)", rows[0]["exposure"] == -1.0,
            f"E = {rows[0]['exposure']}")
    r.check("an empty scene renders black (bytes 0 outside the strip)",
            rows[0]["sphere_bytes"] == [0], f"bytes {rows[0]['sphere_bytes']}")
    r.check("E = -1 does not pass silently (the render warns)",
            all(any("exposure" in w for w in row["warnings"]) for row in black),
            "; ".join(f"radius {row['radius']}: {row['warnings'] or 'no warning'}"
                      for row in black))
    first_hit = next((row["radius"] for row in rows if row["exposure"] != -1.0), None)
    r.threshold = (f"probes miss the sphere up to radius {missed[-1]['radius']:g} px: E = -1 "
                   f"and its pixels show bytes {missed[-1]['sphere_bytes']} (negative tone "
                   f"values wrapped); a probe hits from radius {first_hit:g}"
                   if missed else f"a probe hits from radius {first_hit}")
    r.threshold_value = first_hit
    r.image = image
    r.image_title = "radius 2, E = %g (what the user sees)" % rows[radii.index(2.0)]["exposure"] \
        if 2.0 in radii else ""
    return r
