"""Regenerate the synthetic Paper A optical tribometer logs in this folder.

    python sample_data/optical/regenerate.py [--seed 2019]

The logs follow the test sequence of thesis Tab. 5.2
(:func:`torlab.synth.optical.paper_a_conditions`) with torlab's own model as the
truth (:func:`torlab.synth.optical.model_truth`): the Paper A scenes of
``protocols/scenes/`` (steel ball on glass, 90.1 N, water 1 mPa s, the smooth and
rough balls of Tab. 5.1 with plastic asperities) with the third-body layer
:data:`torlab.synth.optical.PAPER_A_LAYER`.  So the film thickness follows
Eq. 5.31 and the Stribeck and traction curves the mixed model, as Paper A found
them to (thesis chapter 6: "the film thickness measurements verified a good
accuracy of the analytical film prediction formula"; H1.1).  Sampled at 50 Hz
instead of 1 kHz, so that the five logs stay under 2 MB in the repository.
Everything else (servo lag, friction run-in, noise, quantisation, the 25 fps
film camera) is the virtual rig's default.
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
SCENE_DIR = HERE.parent.parent / "protocols" / "scenes"
#: the scene of each test: the dry contact, and the smooth and rough balls with water
SCENES = {"dry": "optical_paper_a_dry.yaml", "smooth": "optical_paper_a_smooth.yaml",
          "rough": "optical_paper_a_rough.yaml"}


def main(argv: list[str] | None = None) -> None:
    from torlab.outputs import OutputDir
    from torlab.protocols.loader import deep_merge, merged_scene_data
    from torlab.scene import scene_from_dict
    from torlab.synth.optical import (
        PAPER_A_LAYER,
        OpticalRig,
        model_truth,
        paper_a_conditions,
        write_optical_log,
    )
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
                           "Tab. 5.2 with torlab's model as the truth (torlab.synth.optical."
                           "model_truth on the Paper A scenes with the layer below), sampled at "
                           f"{SAMPLE_RATE_HZ:g} Hz",
            "seed": args.seed, "rig": asdict(rig), "layer": dict(PAPER_A_LAYER),
            "scenes": dict(SCENES), "tests": []}
        for k, t in enumerate(paper_a_conditions()):
            files = [SCENE_DIR / SCENES["dry" if t.test == "dry_traction" else t.surface]]
            sd = deep_merge(merged_scene_data(files), {"boundary": dict(PAPER_A_LAYER)})
            mu_fn, h_fn, desc = model_truth(t, scene_from_dict(sd, path=str(files[0])))
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
