"""The XML examples that the plugin reference gives for the tutorial's cameras and cube map
(docs/reference/, generated from the docstrings; what a converter copies) load and give the
rays and settings of facts.md F3, F5 and F12."""

from __future__ import annotations

import re

import numpy as np

from support import ROOT
from test_conic import spec_ray

W, H = 640, 480


PAGES = ("sensor-tutorialortho", "sensor-conic", "emitter-cubemap")


def documented_elements(tag: str) -> list[str]:
    text = "".join((ROOT / "docs" / "reference" / f"{page}.md").read_text() for page in PAGES)
    xml = "".join(re.findall(r"```xml\n(.*?)```", text, re.S))
    return [e.replace(f"<{tag} ", f'<{tag} version="3.0.0" ', 1)
            for e in re.findall(rf"(<{tag}\b.*?</{tag}>)", xml, re.S)]


def film_rays(mi, sensor):
    """One ray per film pixel, random jitter inside it and random aperture samples."""
    w, h = sensor.film().size()
    r, c = np.mgrid[0:h, 0:w].reshape(2, -1).astype(np.float64)
    rng = np.random.default_rng(0)
    jitter, lens = rng.uniform(0.01, 0.99, (2, c.size)), rng.random((2, c.size))
    ray, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f((c + jitter[0]) / w, (r + jitter[1]) / h),
                               mi.Point2f(*lens))
    return c, r, lens, np.array(ray.o).T, np.array(ray.d).T, np.array(ray.maxt)


def test_documented_cameras_give_the_tutorial_rays(llvm):
    mi = llvm
    ortho, conic = documented_elements("sensor")
    # Page 1 (640 x 480 film): pixel (x, y) from (x, y, -1000) along +z, t < 2000.
    c, r, _, o, d, maxt = film_rays(mi, mi.load_string(ortho))
    assert np.abs(o[:, 0] - c).max() < 1e-4 and np.abs(o[:, 1] - (H - 1 - r)).max() < 1e-4
    assert np.all(o[:, 2] == -1000) and np.all(d == [0, 0, 1]) and np.all(maxt == 2000)
    # Page 4 (1280 x 960 film): sub-sample (c/2, (959 - r)/2), facts.md F5 lens.
    c, r, lens, o, d, maxt = film_rays(mi, mi.load_string(conic))
    o_ref, d_ref = spec_ray(c / 2, (2 * H - 1 - r) / 2, lens[0], lens[1], 90.0, 450.0, 10.0,
                            w=W, h=H)
    assert np.abs(o - o_ref).max() < 1e-4 and np.abs(d - d_ref).max() < 1e-6
    assert np.all(maxt == 2000)


def test_documented_cubemap_is_the_page4_background(llvm, tutorial_dir):
    mi = llvm
    (element,) = documented_elements("emitter")
    faces = tutorial_dir / "page4"
    emitter = mi.load_string(re.sub(r'value="(alp\w+\.tga)"', lambda m: f'value="{faces / m[1]}"',
                                    element))
    assert len(emitter.names) == 6
    assert (emitter.mode, emitter.srgb, emitter.exposed, emitter.exposure) == (
        "background", True, True, 1.0)
