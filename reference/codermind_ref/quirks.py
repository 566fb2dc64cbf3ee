"""The seven quirks of the original programs that ``clean`` mode removes (facts.md F7, F8, F11).

``strict`` keeps all of them; ``clean`` none. Each can be toggled alone (``Quirks(...)``),
which is how ``benchmarks/quirk_table.py`` measures what each one changes.
Everything else the original does is the model itself and stays in both modes: the off-centre
square aperture and focus sphere, the tone curve applied per sub-sample before averaging, the
probe-grid auto exposure, the lower-left 2x2 sub-sample grid, no light falloff.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Quirks:
    shadow_squared: bool = True
    """pages 2, 4: shadow rays test objects up to the SQUARED light distance, so objects
    beyond the light cast shadows (clean: the true distance)."""
    coef_squared: bool = True
    """page 4: turbulence and marble get coef^2 in the Lambert term (clean: coef)."""
    cubemap_at_limit: bool = True
    """page 4: the cube map is added with the last direction when the 10-segment limit is
    reached (or a zero normal stops the path), whether that direction is blocked or not
    (clean: the ray leaving the 10th segment is traced and adds the cube map only if it
    escapes; a zero normal ends the path black)."""
    inside_retrace: bool = True
    """page 4: a 'diffuse' roulette draw inside an object re-traces the same segment with new
    draws, each try consuming one of the 10 segments (clean: redraw among reflect/refract
    with probabilities Rf/(Rf+Tr), Tr/(Rf+Tr) without consuming a segment; the path ends if
    Rf + Tr = 0)."""
    path_index: bool = True
    """page 4: the Fresnel index n1 is path state, 1 at the camera and n2 after each
    refraction, while n2 follows the side test (Density entering, 1 "inside"); where the side
    test disagrees with the path's history (the blob's exact-field normal says "inside" for
    some rays that come from the air) n1 = n2, R = 0 and the ray passes unbent into the glass,
    which it then crosses with index 1 (clean: n1 follows the side too, Density inside and 1
    outside, as a one-hit BSDF can do)."""
    refraction_length: bool = True
    """page 4: where cosI >= 0.999 (cosT = 1, facts.md F8) the refracted direction
    (n1/n2)(d + cosI n) - n is not unit (up to 1 + 2e-3 long leaving glass, 1 + 2.5e-4
    entering), and the next intersection takes it as unit (the blob's A = 1.0f, the
    tutorial's code; the sphere test's b^2 - c), so the hits along it lie off the surface:
    on page 4's blob by ~0.1 along the ray after ~130 units, where a total internal
    reflection from that point re-enters the glass within 0.1 and the path escapes (bright
    spots near the neck; clean: the direction normalized)."""
    blob_float32: bool = True
    """page 4: the blob's running bound and polynomial coefficients are float32 running sums in
    sorted event order, and the bound's `< 1` test is decided on the float32 value, so a lone
    source's core (bound 0.2 + 8 x 0.1) can come out at 0.99999994 and be skipped: holes in the
    surface, and glass paths that leave the blob from inside without a hit (clean: the bound in
    exact tenths, the polynomial from the zone depths in float64)."""

    @property
    def name(self) -> str:
        if self == STRICT:
            return "strict"
        if self == CLEAN:
            return "clean"
        return "custom(" + ",".join(k for k, v in self.__dict__.items() if v) + ")"


STRICT = Quirks()
CLEAN = Quirks(False, False, False, False, False, False, False)


def resolve(mode: "str | Quirks") -> Quirks:
    """'strict', 'clean' or a Quirks instance."""
    if isinstance(mode, Quirks):
        return mode
    if mode == "strict":
        return STRICT
    if mode == "clean":
        return CLEAN
    raise ValueError(f"mode must be 'strict', 'clean' or a Quirks instance, got {mode!r}")
