"""Learning curve of the CNN + refiner: PCP@0.5 on the 76 shipped test images after
training on 300 (the shipped 224 train images), 1000 and 3000 rendered images.

The bigger training sets are rendered by `training/make_dataset.py` (clips of their own
seed block, disjoint from the test clips) into --work; each run is `training/train_cnn.py`
as a user runs it. Bigger sets train for fewer epochs (--epochs-for), so every run makes
at least the default run's number of Adam steps without taking ten times as long.

    .venv/bin/python benchmarks/cnn_learning_curve.py \
        --json benchmarks/results/cnn_learning_curve.json
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

from imimic_gym.checkpoints import SHIPPED_ANNOTATIONS, SHIPPED_CHECKPOINTS

ROOT = Path(__file__).resolve().parents[1]
# Training images -> (CNN epochs, combined epochs). 300 is the paper's schedule.
EPOCHS_FOR = {300: (10, 100), 1000: (3, 22), 3000: (1, 10)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--links", type=int, nargs="+", default=[1], choices=(1, 2))
    parser.add_argument("--sizes", type=int, nargs="+", default=sorted(EPOCHS_FOR),
                        choices=sorted(EPOCHS_FOR))
    parser.add_argument("--work", default=None, help="folder for the generated annotations "
                        "and checkpoints; what it already holds is reused, so an interrupted "
                        "run resumes (default: a temporary folder)")
    parser.add_argument("--threads", type=int, default=2, help="torch threads per training run")
    parser.add_argument("--retrain-300", action="store_true",
                        help="train the 300-image point again instead of reading the shipped "
                             "checkpoint's metadata")
    parser.add_argument("--json", default=None, help="also write the results here")
    args = parser.parse_args()
    work = Path(args.work or tempfile.mkdtemp(prefix="cnn_curve_"))
    rows = []
    for links in args.links:
        for size in args.sizes:
            cnn_epochs, epochs = EPOCHS_FOR[size]
            train = SHIPPED_ANNOTATIONS / f"arm{links}_train.json"
            if size != 300:
                name = f"arm{links}_{size}"
                train = work / f"{name}_train.json"
                if not train.exists():
                    subprocess.run([sys.executable, str(ROOT / "training" / "make_dataset.py"),
                                    "--links", str(links), "--train-clips", str(size // 4),
                                    "--test-clips", "0", "--name", name, "--out", str(work)],
                                   check=True)
            out = work / f"cnn_arm{links}_{size}.pt"
            if size == 300 and not args.retrain_300:
                out = SHIPPED_CHECKPOINTS / f"cnn_arm{links}.pt"
            command = [sys.executable, str(ROOT / "training" / "train_cnn.py"), "--links",
                       str(links), "--annotations", str(train), "--test-annotations",
                       str(SHIPPED_ANNOTATIONS / f"arm{links}_test.json"), "--cnn-epochs",
                       str(cnn_epochs), "--epochs", str(epochs), "--out", str(out),
                       "--threads", str(args.threads)]
            if out.parent == work and not out.with_suffix(".json").exists():
                subprocess.run(command, check=True, cwd=work)
            meta = json.loads(out.with_suffix(".json").read_text())
            row = {"links": links, "train_images": meta["train_images"],
                   "dataset_images": size, "command": meta["command"],
                   "cnn_epochs": cnn_epochs, "epochs": epochs,
                   "train_seconds": meta["train_seconds"], "cnn": meta["test"]["cnn"],
                   "cnn_refiner": meta["test"]["cnn_refiner"]}
            rows.append(row)
            r = row["cnn_refiner"]["pcp_all"]
            print(f"links {links}, {row['train_images']} images: CNN + refiner PCP@0.5 upper "
                  f"{r['upper']:.3f}, lower {r['lower']:.3f}", flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps({"rows": rows}, indent=2) + "\n")
        print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
