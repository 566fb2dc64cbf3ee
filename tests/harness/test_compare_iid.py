"""compare renders the Mitsuba side of a random scene with the `independent` sampler, so that
both sides' sub-sample means come from the same kind of estimator, which Stouffer's Z of the
per-sub-sample z needs (sides.iid_sampler_xml; the page-4 blob's failure in
docs/results/compare.md). compare's pooled tests are now pooled differences, which do not
need it; the sampler change stays for the per-sub-sample z-test."""

from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]


def _stratified_and_iid(seed: int, p: float = 0.2, shape=(48, 64, 3), n: int = 64, k: int = 16):
    """Two estimators of E[1(u < p) / p] = 1 exactly [fact: closed form]: k passes of m = n/k
    samples stratified over [0, 1) (variance from the pass means, as compare's Mitsuba side),
    and n independent samples (variance from the samples, as the port)."""
    rng = np.random.default_rng(seed)
    m = n // k
    f = lambda u: (u < p) / p            # noqa: E731
    passes = f((np.arange(m) + rng.random(shape + (k, m))) / m).mean(-1)
    strat = passes.mean(-1), passes.var(-1, ddof=1) / k
    iid_passes = f(rng.random(shape + (k, m))).mean(-1)
    iid_a = iid_passes.mean(-1), iid_passes.var(-1, ddof=1) / k
    x = f(rng.random(shape + (n,)))
    iid_b = x.mean(-1), x.var(-1, ddof=1) / n
    return strat, iid_a, iid_b


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_pooled_test_needs_the_same_kind_of_estimator_on_both_sides(seed):
    """The reason for the independent sampler: a stratified estimator against an iid one of
    the SAME exact mean fails the pooled object test (Stouffer Z 4.9 or more over 3072 values;
    critical 3.14), two iid estimators pass it."""
    from codermind_harness.metrics import signed_z, stouffer
    (sa, sv), (ia, iv), (b, bv) = _stratified_and_iid(seed)
    labels = np.zeros(b.shape[:2], dtype=int)
    mixed = stouffer(signed_z(sa, sv, b, bv), labels, "objects")
    same = stouffer(signed_z(ia, iv, b, bv), labels, "objects")
    assert not mixed.passed and mixed.max_abs_z > 4.0, mixed
    assert same.passed and same.max_abs_z < 2.5, same


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_pooled_difference_takes_either_kind_of_estimator(seed):
    """The same stratified and iid estimators of the same exact mean: the pooled difference
    (what compare pools now) passes both pairs."""
    from codermind_harness.metrics import pooled_difference
    (sa, sv), (ia, iv), (b, bv) = _stratified_and_iid(seed)
    labels = np.zeros(b.shape[:2], dtype=int)
    for a, v, dof in ((sa, sv, 15), (ia, iv, 15)):
        p = pooled_difference(a, v, b, bv, labels, "objects", dof, 63)
        assert p.passed and p.max_abs_z < 3.0, p


def test_iid_sampler_xml_replaces_only_the_camera_sampler():
    from codermind_harness.sides import iid_sampler_xml
    text = (ROOT / "scenes" / "page4.xml").read_text(encoding="utf-8")
    assert text.count('<sampler type="multijitter">') == 1
    new = iid_sampler_xml(text)
    assert '<sampler type="multijitter">' not in new
    camera, probes = new.split("<sensor")[1:3]
    assert '<sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>' \
        in camera
    assert probes == text.split("<sensor")[2]          # the probe sensor is left as it is
    assert iid_sampler_xml(new) == new
    bare = '<scene version="3.0.0"><sensor type="perspective"/></scene>'
    assert iid_sampler_xml(bare) == bare
    second = ('<scene><sensor type="perspective"><film type="hdrfilm"/></sensor>'
              '<sensor type="perspective"><sampler type="multijitter"/></sensor></scene>')
    assert iid_sampler_xml(second) == second       # only the FIRST sensor's sampler
    bare_first = second.replace('<sensor type="perspective"><film type="hdrfilm"/></sensor>',
                                '<sensor type="perspective"/>')
    assert iid_sampler_xml(bare_first) == bare_first


def test_load_mitsuba_iid_gives_the_independent_sampler(llvm):
    from codermind_harness.sides import Grid, load_mitsuba
    xml = ROOT / "scenes" / "page1.xml"
    for grid in (Grid.of(640, 480, 1), Grid.of(640, 480, 1, (0, 0, 8, 8))):
        scene, _ = load_mitsuba(xml, grid, {"spp": "4"}, iid=True)
        assert str(scene.sensors()[0].sampler()).startswith("IndependentSampler")


def test_compare_asks_for_iid_on_random_scenes_only(monkeypatch, tmp_path):
    """compare_scene's Mitsuba render gets iid=True on page 4 (random) and False on page 1."""
    from codermind_harness import compare, sides
    seen = []

    class Stop(Exception):
        pass

    def fake(*args, **kwargs):
        seen.append(kwargs.get("iid"))
        raise Stop

    monkeypatch.setattr(sides, "render_mitsuba", fake)
    monkeypatch.setattr(sides, "port_exposures", lambda *a, **k: [1.0, 1.0])
    monkeypatch.setattr(sides, "port_exposure", lambda *a, **k: None)
    monkeypatch.setattr(sides, "render_port", lambda *a, **k: None)
    for name in ("page4", "page1"):
        opt = compare.Options(rect=(100, 100, 102, 102), out_dir=tmp_path / name, progress=False,
                              exposure_seeds=2, spp=2 if name == "page4" else None)
        with pytest.raises(Stop):
            compare.compare_scene(ROOT / "scenes" / f"{name}.xml", opt)
    assert seen == [True, False]


def test_sampler_xml_sets_any_kind_and_refuses_a_missing_sampler():
    """bench_samplers.py swaps the camera sampler through the same function."""
    from codermind_harness.sides import sampler_xml
    text = (ROOT / "scenes" / "page4.xml").read_text(encoding="utf-8")
    camera = sampler_xml(text, "ldsampler").split("<sensor")[1]
    assert '<sampler type="ldsampler"><integer name="sample_count" value="$spp"/></sampler>' \
        in camera
    with pytest.raises(ValueError, match="no sensor sampler"):
        sampler_xml('<scene><sensor type="perspective"/></scene>', "stratified")
