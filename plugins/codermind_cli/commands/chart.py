"""Speed versus accuracy: for each bundled tutorial scene, error (relative MSE and mean FLIP
against a converged reference) versus wall time for the Mitsuba side (spp and blob
max_error sweeps, scalar_rgb and llvm_ad_rgb), the port in clean mode (Complexity sweep) and
the model chooser's pick against the maximal model, with the Pareto front; and how the cost
grows with pixels, spp, blob sources and mesh triangles. Writes OUTDIR/error_vs_time_<scene>
.png/.csv, cost_scaling.png/.csv and chart.json, and prints a table. Progress on stderr."""

from __future__ import annotations

import argparse
from pathlib import Path

NAME = "chart"
HELP = "speed vs accuracy charts (error vs time, Pareto fronts, cost scaling)"
SCENES = ("page1", "page2", "page3", "page4", "garden")


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("-o", "--output", metavar="OUTDIR", default="chart",
                   help="folder for the PNG, CSV and chart.json files (default: ./chart)")
    p.add_argument("--quick", action="store_true",
                   help="tiny crops, few samples, one repeat (seconds; for tests)")
    p.add_argument("--only", nargs="+", metavar="SCENE", choices=SCENES,
                   help="chart only these scenes: " + ", ".join(SCENES))
    p.add_argument("--no-cost", action="store_true",
                   help="skip the cost-scaling experiments")
    p.add_argument("--cluster", metavar="ADDRESS",
                   help="run on a Dask cluster: tcp://HOST:PORT (a `dask scheduler`) or local:N "
                        "(N worker processes here); default: this machine; one point per task, the "
                        "cost-scaling experiments stay here")
    p.add_argument("--scenes", metavar="DIR",
                   help="folder of the bundled scenes (default: the repository's scenes/, "
                        "or the copy installed with the package)")


def run(args: argparse.Namespace) -> int:
    import os
    from codermind.errors import CodermindError
    if args.scenes is not None:
        if not (Path(args.scenes) / "page1.xml").is_file():
            raise CodermindError(f"--scenes {args.scenes}: not a folder of the bundled "
                                 f"scenes (no page1.xml)")
        os.environ["CODERMIND_SCENES"] = str(Path(args.scenes).resolve())
    from codermind_harness import chart
    from codermind_harness.cluster import open_runner
    from codermind_harness.sides import HarnessError
    try:
        with open_runner(args.cluster) as runner:
            paths, table = chart.run(Path(args.output), args.only, quick=args.quick,
                                     cost=not args.no_cost, runner=runner)
    except HarnessError as e:
        raise CodermindError(str(e)) from None
    except OSError as e:
        raise CodermindError(f"{e.filename or args.output}: cannot write: "
                             f"{e.strerror or e}") from None
    print(table, end="")
    print(f"wrote {len(paths)} files to {args.output}")
    return 0
