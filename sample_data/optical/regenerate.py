"""Regenerate the synthetic Paper A optical tribometer logs in this folder.

    python sample_data/optical/regenerate.py [--seed 2019]

The logs follow the test sequence of thesis Tab. 5.2
(:func:`torlab.synth.optical.paper_a_conditions`) with the analytic stand-in truth
of :func:`torlab.synth.optical.demo_truth` -- the same generator and seeds as
``torlab synth optical`` -- but sampled at 50 Hz instead of 1 kHz, so that the
five logs stay under 2 MB in the repository.  Everything else (servo lag,
friction run-in, noise, quantisation, the 25 fps film camera) is the virtual
rig's default.
"""

from __future__ import annotations

import argparse
import os
import shutil
import tempfile
from dataclasses import asdict
from pathlib import Path

HERE = Path(__file__).resolve().parent
SAMPLE_RATE_HZ = 50.0


def main(argv: list[str] | None = None) -> None:
    from torlab.outputs import OutputDir
    from torlab.synth.optical import OpticalRig, demo_truth, paper_a_conditions, write_optical_log
    from torlab.yamlio import dump_yaml

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=2019)
    ap.add_argument("-o", "--out", type=Path, default=HERE,
                    help="folder to write to (default: this folder; its logs are replaced)")
    args = ap.parse_args(argv)
    rig = OpticalRig(sample_rate_hz=SAMPLE_RATE_HZ)
    # generated into a fresh staging folder, then moved next to this script and its README
    # (which are not generated and so must not be in the manifest's way)
    tmp = Path(tempfile.mkdtemp(prefix=".optical-", dir=args.out.resolve().parent))
    dest = OutputDir(tmp / "new", command=f"python sample_data/optical/regenerate.py "
                     f"--seed {args.seed}")
    try:
        truth = {
            "description": "SYNTHETIC optical tribometer logs: Paper A test sequence of thesis "
                           "Tab. 5.2 with the analytic stand-in truth of "
                           "torlab.synth.optical.demo_truth (not the torlab model), sampled at "
                           f"{SAMPLE_RATE_HZ:g} Hz",
            "seed": args.seed, "rig": asdict(rig), "tests": []}
        for k, t in enumerate(paper_a_conditions()):
            mu_fn, h_fn, desc = demo_truth(t)
            rows = write_optical_log(dest.path(f"{t.name}.csv"), t, mu_fn, h_fn, rig=rig,
                                     seed=args.seed + k, notes=f"demo truth: {desc}")
            truth["tests"].append({"file": f"{t.name}.csv", "test": t.test, "surface": t.surface,
                                   "lubricant": t.lubricant, "window_s": t.window_s, "seed": args.seed + k,
                                   "truth": desc, "conditions": rows})
        dest.write_text("truth.yaml", dump_yaml(truth))
    except BaseException:
        dest.abort()
        raise
    new = dest.commit()
    args.out.mkdir(parents=True, exist_ok=True)
    for f in sorted(new.iterdir()):
        os.replace(f, args.out / f.name)
    shutil.rmtree(tmp)


if __name__ == "__main__":
    main()
