"""Where the port (clean) and Mitsuba differ on `codermind chart`'s page-4 crop: the port at
Complexity 32 against Mitsuba's full model (blob max_error 0.02) at 256 spp, both with their
per-sub-sample variances; prints the rel MSE against the noise it should have, the
sub-samples with |z| > 5 and where they lie, and the share of the top 1 % of pixels.

    python benchmarks/chart_port_bias.py        # about 2 min on the 2-core machine
"""

from __future__ import annotations

import numpy as np

import codermind_ref as ref
from codermind_harness import chart, chart_data
from codermind_harness.sides import parse, port_exposure, twin_of

RECT = chart_data.FULL.crops["page4"]


def main() -> None:
    from codermind.variants import set_variant
    set_variant("llvm_ad_rgb")
    txt, xml = twin_of(chart_data.ROOT / "scenes" / "page4.xml")
    scene = parse(txt)
    exposure = port_exposure(scene, chart_data.PORT_SEED)
    runner = chart.MitsubaRunner(xml, scene.width, scene.height, scene.page)
    m, mv, *_ = runner.render(RECT, {"blob0_max_error": 0.02}, 256, 77, variance=True,
                              label="mitsuba 256 spp")
    r = ref.render(scene, "clean", 5, 32, exposure=exposure, rect=RECT, workers=2)
    p, pv = r.linear.astype(float), r.variance.astype(float)
    guard = np.square(m) + 0.01
    print(f"rel MSE {np.mean(np.square(p - m) / guard):.4g}, expected from the noise "
          f"{np.mean((mv + pv) / guard):.4g}")
    noisy = (mv + pv) > 0
    z = np.where(noisy, (p - m) / np.sqrt(np.where(noisy, mv + pv, 1.0)), 0.0)
    bad = np.abs(z).max(axis=2) > 5
    rows, cols = np.nonzero(bad)
    x = RECT[0] + cols / 2
    y = RECT[3] - (rows + 1) / 2
    print(f"|z| > 5 in {bad.sum()} of {bad.size} sub-samples; x 10/50/90 %: "
          f"{np.percentile(x, [10, 50, 90])}, y (up): {np.percentile(y, [10, 50, 90])}")
    per = np.sort((np.square(p - m) / guard).mean(axis=2).ravel())[::-1]
    print(f"share of the squared difference in the top 1 % of sub-samples: "
          f"{per[:per.size // 100].sum() / per.sum():.2f}")


if __name__ == "__main__":
    main()
