"""`codermind render`: outputs, determinism, pass accumulation, errors, interruption."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from support import ROOT, run_cli

SCENE = """<scene version="3.0.0">
    {integrator}
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0, 1, -5" target="0, 0.3, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="16"/></sampler>
        <film type="hdrfilm">
            <integer name="width" value="{width}"/><integer name="height" value="{height}"/>
        </film>
    </sensor>
    <emitter type="constant"><rgb name="radiance" value="0.5"/></emitter>
    <emitter type="tutorialpoint"><point name="position" x="2" y="3" z="-2"/><rgb name="intensity" value="1.5"/></emitter>
    <shape type="sphere"><bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.4, 0.2"/></bsdf></shape>
    <shape type="rectangle">
        <transform name="to_world"><rotate x="1" angle="-90"/><translate y="-1"/><scale value="4"/></transform>
        <bsdf type="diffuse"/>
    </shape>
</scene>
"""


PATH = '<integrator type="path"/>'
MOMENT = '<integrator type="moment"><integrator type="path"/></integrator>'


def write_scene(folder: Path, integrator: str = PATH, width: int = 48, height: int = 32) -> Path:
    path = folder / "scene.xml"
    path.write_text(SCENE.format(integrator=integrator, width=width, height=height))
    return path


def read_exr(path: Path) -> np.ndarray:
    import mitsuba as mi
    if mi.variant() is None:
        mi.set_variant("scalar_rgb")
    return np.array(mi.Bitmap(str(path)), dtype=np.float32)


def test_writes_exr_and_png_side_by_side(tmp_path):
    scene = write_scene(tmp_path)
    out = run_cli("render", scene, "-o", tmp_path / "img", "--spp", "4")
    assert out.returncode == 0, out.stderr
    exr = read_exr(tmp_path / "img.exr")
    assert exr.shape == (32, 48, 3) and np.isfinite(exr).all() and exr.max() > 0
    png = (tmp_path / "img.png").read_bytes()
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "img.exr", "img.manifest.json", "img.png", "scene.xml"]


def test_fixed_seed_gives_a_bit_identical_exr(tmp_path):
    # Default (Gaussian) reconstruction filter: neighbouring pixels receive samples from
    # other threads, which is why --deterministic is needed for bit-identical output.
    scene = write_scene(tmp_path)
    for name in ("a", "b"):
        out = run_cli("render", scene, "-o", tmp_path / name, "--spp", "32", "--pass-spp", "8",
                      "--seed", "7", "--deterministic")
        assert out.returncode == 0, out.stderr
    assert (tmp_path / "a.exr").read_bytes() == (tmp_path / "b.exr").read_bytes()
    out = run_cli("render", scene, "-o", tmp_path / "c", "--spp", "32", "--pass-spp", "8",
                  "--seed", "8", "--deterministic")
    assert (tmp_path / "a.exr").read_bytes() != (tmp_path / "c.exr").read_bytes()


def test_pass_split_is_exact_and_seeds_are_distinct():
    from codermind.passes import pass_plan, pass_seed
    assert pass_plan(10, 100, pass_spp=4) == [4, 4, 2]
    assert sum(pass_plan(1000, 640 * 480)) == 1000
    seeds = {pass_seed(s, i) for s in range(20) for i in range(50)}
    assert len(seeds) == 1000


# The samplers whose kept counts the converter knows from Mitsuba's plugin docs
# (codermind.tutorial.xml.sampler_fits): any, squares, powers of 4, squares of primes.
KINDS = ("independent", "ldsampler", "orthogonal", "stratified")


@pytest.mark.parametrize("kind", KINDS)
def test_sampler_plan_passes_are_counts_the_sampler_keeps(llvm, kind):
    """Every pass of the plan is a count that the sampler does not round up (so a pass renders
    what it counts), and the passes add up to the request."""
    mi = llvm
    from codermind.passes import sampler_plan
    from codermind.tutorial.xml import sampler_fits
    sampler = mi.load_dict({"type": kind, "sample_count": 4})
    for spp in (16, 49, 64, 100, 256, 1024):
        if kind == "ldsampler" and spp == 49:       # refused (next test)
            continue
        plan = sampler_plan(sampler, spp, 1280 * 960)
        assert sum(plan) == spp
        assert all(sampler_fits(kind, n) for n in plan), (kind, spp, plan)
    assert sampler.sample_count() == 4


def test_sampler_plan_keeps_a_stratified_set_whole(llvm):
    """On page 4's film (1280 x 960 sub-samples) 64 spp is one multijitter pass (a stratified
    set of 64), where the lane budget alone would split it 27 + 27 + 10; independent samples
    keep that split."""
    mi = llvm
    from codermind.passes import pass_plan, sampler_plan
    pixels = 1280 * 960
    mj = mi.load_dict({"type": "multijitter", "sample_count": 4})
    iid = mi.load_dict({"type": "independent", "sample_count": 4})
    assert sampler_plan(mj, 64, pixels) == [64]
    assert sampler_plan(mj, 1024, pixels) == [64] * 16
    assert sampler_plan(iid, 64, pixels) == pass_plan(64, pixels) == [27, 27, 10]


def test_sampler_plan_refuses_a_count_without_kept_passes(llvm):
    mi = llvm
    from codermind.errors import CodermindError
    from codermind.passes import sampler_plan
    with pytest.raises(CodermindError, match="LowDiscrepancySampler: it rounds 49 .* up to 64"):
        sampler_plan(mi.load_dict({"type": "ldsampler", "sample_count": 4}), 49, 100)


def test_passes_accumulate_to_the_same_mean_as_one_render(tmp_path, llvm):
    """Per-pixel two-sample z-test on the first moments (moment integrator), Sidak-corrected
    alpha = 0.01 over all pixel channels: the accumulated passes and one single render must
    be statistically equal."""
    mi = llvm
    from codermind.passes import render_passes
    from codermind.scene import load_scene
    scene = load_scene(write_scene(tmp_path, integrator=MOMENT))
    spp = 64
    passes = render_passes(scene, spp=spp, seed=1, pass_spp=4)
    single = render_passes(scene, spp=spp, seed=2, pass_spp=spp)
    assert passes.spp == single.spp == spp and len(passes.pass_times) == 16

    def mean_var(img):
        # channels: R, G, B, then the moment integrator's first and second moments
        m1, m2 = img[..., 3:6].astype(np.float64), img[..., 6:9].astype(np.float64)
        return m1, np.maximum(m2 - m1 * m1, 0) / spp

    (ma, va), (mb, vb) = mean_var(passes.image), mean_var(single.image)
    assert passes.image.shape[-1] == 9
    z = np.abs(ma - mb) / np.sqrt(np.maximum(va + vb, 1e-12))
    alpha = 1 - (1 - 0.01) ** (1 / z.size)
    from statistics import NormalDist
    z_crit = NormalDist().inv_cdf(1 - alpha / 2)
    assert (z > z_crit).mean() <= 0.01
    # and the test has teeth: a 5% brighter image fails it
    z_bad = np.abs(ma * 1.05 - mb) / np.sqrt(np.maximum(va + vb, 1e-12))
    assert (z_bad > z_crit).mean() > 0.05


def _one_line_error(out: subprocess.CompletedProcess) -> str:
    assert out.returncode == 2, (out.stdout, out.stderr)
    assert "Traceback" not in out.stderr
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1, out.stderr
    assert lines[0].startswith("codermind: error: ")
    return lines[0]


def test_malformed_xml_gives_exit_2_and_one_line(tmp_path):
    bad = tmp_path / "broken.xml"
    bad.write_text(SCENE.format(integrator=PATH, width=8, height=8).replace("</shape>", "</shap>", 1))
    line = _one_line_error(run_cli("render", bad, "-o", tmp_path / "x"))
    assert "broken.xml" in line and "line" in line


def test_unknown_parameter_names_file_and_parameter(tmp_path):
    bad = tmp_path / "param.xml"
    bad.write_text(SCENE.format(integrator=PATH, width=8, height=8).replace(
        '<float name="fov" value="40"/>', '<float name="fvo" value="40"/>'))
    line = _one_line_error(run_cli("render", bad, "-o", tmp_path / "x"))
    assert "param.xml" in line and '"fvo"' in line


def test_bad_scene_path_gives_exit_2(tmp_path):
    line = _one_line_error(run_cli("render", tmp_path / "missing.xml"))
    assert "missing.xml" in line


def test_bad_variant_gives_exit_2(tmp_path):
    line = _one_line_error(run_cli("render", write_scene(tmp_path), "--variant", "nope"))
    assert "--variant" in line


def test_scalar_variant_renders(tmp_path):
    scene = write_scene(tmp_path, width=12, height=8)
    out = run_cli("render", scene, "-o", tmp_path / "s", "--spp", "2", "--variant", "scalar_rgb")
    assert out.returncode == 0, out.stderr
    assert np.isfinite(read_exr(tmp_path / "s.exr")).all()


def test_error_raised_inside_the_render_is_the_plugin_s_own(tmp_path):
    """strict tutorialpath refuses the scene's environment light when the render starts: the
    user reads that refusal, not Dr.Jit's wrapper ("... (see above)") around it."""
    strict = '<integrator type="tutorialpath"><string name="quirks" value="strict"/></integrator>'
    line = _one_line_error(run_cli("render", write_scene(tmp_path, strict, 8, 8),
                                   "-o", tmp_path / "s"))
    assert "tutorialpath: quirks=strict has no light source" in line
    assert "see above" not in line and not list(tmp_path.glob("s.*"))


@pytest.mark.parametrize("variant", ["llvm_ad_mono", "llvm_ad_spectral"])
def test_unsupported_variant_is_refused_in_one_line_before_rendering(tmp_path, variant):
    """The plugins support the RGB variants: in another, the scene's first plugin of ours
    (here tutorialpoint) refuses it while the scene loads, naming itself and the variant."""
    line = _one_line_error(run_cli("render", write_scene(tmp_path, width=8, height=8),
                                   "-o", tmp_path / "s", "--variant", variant))
    assert "tutorialpoint: the variant" in line and variant in line and "scene.xml" in line
    assert not list(tmp_path.glob("s.*"))


def test_mono_variant_renders_a_scene_of_builtins(tmp_path):
    """A scene of Mitsuba's own plugins renders in llvm_ad_mono: a one-channel EXR and the
    PNG in grey (R = G = B)."""
    scene = tmp_path / "plain.xml"
    scene.write_text(SCENE.format(integrator=PATH, width=12, height=8).replace(
        '<emitter type="tutorialpoint"><point name="position" x="2" y="3" z="-2"/>'
        '<rgb name="intensity" value="1.5"/></emitter>', ""))
    out = run_cli("render", scene, "-o", tmp_path / "m", "--spp", "2", "--variant",
                  "llvm_ad_mono")
    assert out.returncode == 0, out.stderr
    assert read_exr(tmp_path / "m.exr").shape == (8, 12)     # one channel: luminance
    import mitsuba as mi
    png = np.array(mi.Bitmap(str(tmp_path / "m.png")))
    assert png.shape == (8, 12, 3) and (png[..., 0] == png[..., 1]).all() and png.max() > 0


def test_ctrl_c_writes_the_finished_passes_and_no_temp_files(tmp_path):
    scene = write_scene(tmp_path, width=64, height=48)
    proc = subprocess.Popen(
        [sys.executable, "-m", "codermind_cli", "render", str(scene), "-o", str(tmp_path / "part"),
         "--spp", "4096", "--pass-spp", "1"],
        stderr=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    deadline = time.time() + 120
    seen = 0
    for line in proc.stderr:             # progress: one line per pass when not a terminal
        seen += "pass" in line
        if seen >= 3 or time.time() > deadline:
            break
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "interrupted" in err
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == ["part.exr", "part.manifest.json", "part.png", "scene.xml"], names
    img = read_exr(tmp_path / "part.exr")
    assert img.shape == (48, 64, 3) and np.isfinite(img).all() and img.mean() > 0


def test_python_dash_m_and_console_script_agree():
    exe = Path(sys.executable).with_name("codermind")
    out = subprocess.run([str(exe), "--help"], capture_output=True, text=True)
    assert out.returncode == 0 and "render" in out.stdout
    assert run_cli("--help").stdout == out.stdout.replace(exe.name, "codermind")


@pytest.mark.parametrize("body, words", [
    ('<integrator type="path"/><shape type="sphere"/>', "no sensor"),
    ('<sensor type="perspective"/><shape type="sphere"/>', "no integrator"),
])
def test_scene_without_sensor_or_integrator_gives_exit_2(tmp_path, body, words):
    scene = tmp_path / "incomplete.xml"
    scene.write_text(f'<scene version="3.0.0">{body}</scene>')
    line = _one_line_error(run_cli("render", scene, "-o", tmp_path / "x"))
    assert "incomplete.xml" in line and words in line
