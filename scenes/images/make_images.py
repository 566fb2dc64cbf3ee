"""Render the images of the bundled scenes (README, docs) into this folder (PNG only).

Run from anywhere: ``.venv/bin/python scenes/images/make_images.py [--only NAME ...]``.
The tutorial scenes go through ``codermind render`` with the tutorial's image pipeline at the
model ``codermind convert`` chose (seed 0); the physically based ``garden.xml`` at 256
samples per pixel. The EXR and TGA outputs are left in a temporary folder.
"""

from __future__ import annotations

import argparse
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
SCENES = HERE.parent
JOBS = {
    "page1": [],
    "page2": [],
    "page3": [],
    "page4": [],
    "garden": ["-D", "spp=256"],
}


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--only", nargs="*", choices=sorted(JOBS))
    args = p.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        for name in args.only or JOBS:
            out = Path(tmp) / name
            cmd = [sys.executable, "-m", "codermind_cli", "render", str(SCENES / f"{name}.xml"),
                   "-o", str(out), "--seed", "0", *JOBS[name]]
            print(" ".join(cmd[2:]), flush=True)
            subprocess.run(cmd, check=True)
            shutil.copyfile(out.with_suffix(".png"), HERE / f"{name}.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
