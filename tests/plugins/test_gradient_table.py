"""Every differentiable parameter of every plugin, AD against finite differences: the
default-options row of each parameter and a few others of the gradient table
(tests/support/gradient_cases.py, where the rows, the scenes and the tolerance are explained;
``python benchmarks/gradients.py --write-results`` runs every row with more samples and
writes docs/results/gradients.md).

Evidence: Mitsuba's own AD integrators (``prb``, ``prb_projective``) against finite
differences of Mitsuba's own primal renders of the same scenes at the same seeds. That
checks that each plugin attaches its parameters to the AD graph with the right
derivative (the wiring), not that the renderer is right. One Mitsuba built-in
equivalent is an outside fact: ``tutorialpoint`` with falloff against ``point``."""

from __future__ import annotations

import numpy as np
import pytest

from support import gradient_cases as cases
from support import set_variant


def _rows():
    """The CI rows, found when the tests are collected (loading the setups' scenes)."""
    mi = set_variant("llvm_ad_rgb")
    setups = [s for s in cases.SETUPS if s.default or s.ci]
    return [row for row in cases.rows(mi, setups) if row.ci]


CI_ROWS = _rows()
cases.forget()


@pytest.fixture(scope="module", autouse=True)
def _no_scene_outlives_the_module():
    """The table's scenes are dropped after this module, so that they do not slow the
    renders of the tests that follow on the same worker."""
    yield
    cases.forget()


@pytest.mark.parametrize("row", CI_ROWS, ids=[row.id for row in CI_ROWS])
def test_derivative_matches_finite_differences(llvm, row):
    """The derivative of the mean pixel along the row's direction against central
    differences at the same seed, within the tolerance derived from the differences' own
    noise. A row whose derivative is 0 by construction must get 0; a row that cannot be
    right is skipped with its reason."""
    if row.skip:
        pytest.skip(row.skip)
    result = cases.measure(llvm, row)
    print(result.describe())                      # shown with pytest -s
    assert result.finite, result.describe()
    if row.zero:
        assert abs(result.ad) <= result.tolerance, result.describe()
        return
    assert result.resolved, "the derivative is lost in the noise: " + result.describe()
    assert result.error <= result.tolerance, result.describe()


def _all_setups(mi):
    return [(setup, *cases.scene_rows(mi, setup)) for setup in cases.SETUPS]


def test_every_plugin_is_in_the_table(llvm):
    """Every registered plugin appears in some setup's scene (so each of its
    differentiable parameters has rows), and each setup instantiates its own plugin."""
    from codermind.registry import plugin_modules
    found = set()
    for setup, _, names in _all_setups(llvm):
        assert setup.plugin in names, setup.id
        found |= names
    assert {name.rsplit(".", 1)[1] for name in plugin_modules()} <= found


def test_every_differentiable_parameter_has_a_default_row(llvm):
    """Each plugin has one setup with its default options, and every parameter of it
    that any setup finds has a row there (the rows CI runs)."""
    found, default = {}, {}
    for setup, rows, _ in _all_setups(llvm):
        if setup.default:
            assert setup.plugin not in default, f"two default setups of {setup.plugin}"
            default[setup.plugin] = {row.name for row in rows if row.owner == setup.plugin}
        for row in rows:
            found.setdefault(row.owner, set()).add(row.name)
    for owner, names in found.items():
        assert names <= default.get(owner, set()), owner


def test_what_setups_say_names_their_rows(llvm):
    """A step, skip, zero or CI entry names a row of its setup (a renamed parameter or a
    typo would silently do nothing)."""
    for setup, rows, _ in _all_setups(llvm):
        names = {row.name for row in rows}
        for said in (setup.steps, setup.skip, setup.zero, setup.ci):
            assert set(said) <= names, (setup.id, set(said) - names)


def test_rows_are_our_differentiable_keys(llvm):
    """The rule that finds rows: the blob's centres and radius, not its mesh buffers (a
    bare mi.Mesh's) nor its non-differentiable max_error; the tutorial BSDF's colours
    through their Mitsuba ``rgb`` textures; nothing of Mitsuba's own light or BSDF."""
    mi = llvm
    blob = next(s for s in cases.SETUPS if s.plugin == "blob" and s.default)
    rows, _ = cases.scene_rows(mi, blob)
    assert {row.key for row in rows} == {"obj.centers", "obj.radius"}
    assert all(row.discontinuous for row in rows)
    params = mi.traverse(cases.load(mi, blob))
    assert "obj.vertex_positions" in params.keys() and "light.intensity.value" in \
        params.keys()
    page4 = next(s for s in cases.SETUPS if s.id == "tutorial[page=4]")
    rows, _ = cases.scene_rows(mi, page4)
    assert {row.param for row in rows} == {"diffuse.value", "specular.value", "power",
                                           "reflection", "refraction", "density"}
    assert not any(row.discontinuous for row in rows)


def test_tutorialpoint_with_falloff_has_the_derivative_of_point(llvm):
    """Outside fact: with falloff the plugin is Mitsuba's ``point`` light, so the
    derivative image of its intensity is that of ``point`` at the same seed, bit for
    bit (the table's scene, and the same scene with ``point``)."""
    mi = llvm
    setup = next(s for s in cases.SETUPS if s.id == "tutorialpoint[falloff=true]")
    builtin = setup.build(mi, cases.integrator_dict(setup, "prb"))
    builtin["light"] = {**builtin["light"], "type": "point"}
    del builtin["light"]["falloff"]
    key = "light.intensity.value"
    images = []
    for scene in (cases.load(mi, setup), mi.load_dict(builtin)):
        derivatives = cases.Derivatives(mi, scene, [key], spp=16)
        images.append(derivatives.forward(key, np.array([0.7, 0.8, 0.9]), seed=1))
        derivatives.restore()
    assert np.abs(images[1]).max() > 0
    np.testing.assert_array_equal(images[0], images[1])
