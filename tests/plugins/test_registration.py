"""Plugin registration: on import, and again after every variant switch."""

from __future__ import annotations

import subprocess
import sys

import pytest

POINT = {"type": "tutorialpoint", "position": [1.0, 2.0, 3.0]}


def test_every_plugin_module_is_discovered(llvm):
    from codermind import registry
    names = [m.rsplit(".", 1)[1] for m in registry.plugin_modules()]
    assert "tutorialpoint" in names
    assert len(names) == len(set(names)), "two plugin modules share an XML type name"


def test_registration_survives_variant_switches():
    import mitsuba as mi
    import codermind  # noqa: F401
    for variant in ["scalar_rgb", "llvm_ad_rgb", "scalar_rgb", "llvm_ad_rgb"]:
        mi.set_variant(variant)
        emitter = mi.load_dict(POINT)
        assert type(emitter).__name__ == "TutorialPointLight"
        # The instance belongs to the variant that is active now.
        assert emitter.variant_name() == variant


def test_import_before_any_variant_registers_at_first_switch():
    code = ("import mitsuba as mi, codermind\n"
            "assert mi.variant() is None\n"
            "mi.set_variant('scalar_rgb')\n"
            f"print(type(mi.load_dict({POINT!r})).__name__)\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "TutorialPointLight"


def test_entry_point_is_declared():
    from importlib.metadata import entry_points
    eps = entry_points(group="mitsuba")
    assert any(ep.value == "codermind" for ep in eps)


def test_plugin_error_names_the_parameter(llvm):
    mi = llvm
    with pytest.raises(Exception, match="position"):
        mi.load_dict({**POINT, "to_world": mi.ScalarTransform4f().translate([1, 2, 3])})


def test_helpers_without_mitsuba_keep_their_identity_across_switches():
    import mitsuba as mi
    import codermind  # noqa: F401
    from codermind import blobmesh
    error_type = blobmesh.BlobMeshError
    mi.set_variant("scalar_rgb")
    mi.set_variant("llvm_ad_rgb")
    assert blobmesh.BlobMeshError is error_type


@pytest.mark.parametrize("variant", ["llvm_ad_mono", "scalar_spectral", "llvm_ad_spectral_polarized"])
def test_other_variants_refuse_every_plugin_in_one_line(variant):
    """Outside the RGB variants each plugin of ours refuses to be built, in one line naming
    itself and the variant; back in an RGB variant they build again."""
    import mitsuba as mi
    import codermind  # noqa: F401
    from codermind import registry
    from codermind.errors import one_line
    names = [m.rsplit(".", 1)[1] for m in registry.plugin_modules()]
    mi.set_variant(variant)
    try:
        for name in names:
            with pytest.raises(RuntimeError) as e:
                mi.load_dict({"type": name})
            assert f"{name}: the variant '{variant}' is not supported" in one_line(str(e.value))
    finally:
        mi.set_variant("llvm_ad_rgb")
    assert type(mi.load_dict(POINT)).__name__ == "TutorialPointLight"
