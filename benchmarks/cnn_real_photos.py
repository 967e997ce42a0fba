"""The shipped CNN + refiner on real photos: the 48 annotated COCO photos of
../shared/realdata/coco_mini (evaluation only: read in place, never copied).

1. Each shipped checkpoint, as trained on rendered images, scored on all 48 photos
   (`train_cnn.py --eval-only ... --annotations ... --images ...`).
2. The cheapest way to close the gap, tried: fine-tune the checkpoint on a few labelled
   real photos (`train_cnn.py --init ...`, a seeded 36/12 split of the 48), and score the
   fine-tuned and the original network on the same 12 held-out photos.

    .venv/bin/python benchmarks/cnn_real_photos.py --json benchmarks/results/cnn_real_photos.json
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

from imimic_gym.checkpoints import SHIPPED_CHECKPOINTS

ROOT = Path(__file__).resolve().parents[1]
COCO = ROOT.parent / "shared" / "realdata" / "coco_mini"
TRAIN = ROOT / "training" / "train_cnn.py"


def eval_only(checkpoint: Path, annotations: Path, images: Path, out: Path) -> dict:
    subprocess.run([sys.executable, str(TRAIN), "--eval-only", str(checkpoint), "--annotations",
                    str(annotations), "--images", str(images), "--json", str(out)], check=True)
    return json.loads(out.read_text())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--coco", default=str(COCO), help="folder with person_keypoints.json "
                        "and images/ (default: %(default)s)")
    parser.add_argument("--finetune-epochs", type=int, default=60)
    parser.add_argument("--json", default=None, help="also write the results here")
    args = parser.parse_args()
    coco = Path(args.coco)
    annotations, images = coco / "person_keypoints.json", coco / "images"
    if not annotations.is_file():
        sys.exit(f"{annotations} not found: this benchmark needs the real photos")
    print(f"reading real photos from {coco} (evaluation only)")
    work = Path(tempfile.mkdtemp(prefix="cnn_real_"))
    result: dict = {"photos": str(coco), "finetune_epochs": args.finetune_epochs, "rows": []}
    for links in (1, 2):
        checkpoint = SHIPPED_CHECKPOINTS / f"cnn_arm{links}.pt"
        shipped = eval_only(checkpoint, annotations, images, work / f"all_{links}.json")
        tuned = work / f"tuned_arm{links}.pt"
        subprocess.run([sys.executable, str(TRAIN), "--links", str(links), "--init",
                        str(checkpoint), "--annotations", str(annotations), "--images",
                        str(images), "--cnn-epochs", "0", "--epochs", str(args.finetune_epochs),
                        "--out", str(tuned)], check=True, cwd=work)
        split = next((work / "runs").glob(f"cnn_arm{links}__*/split_test.json"))
        before = eval_only(checkpoint, split, images, work / f"before_{links}.json")
        after = eval_only(tuned, split, images, work / f"after_{links}.json")
        result["rows"].append({
            "links": links, "all_photos": shipped,
            "held_out_before": before, "held_out_after_finetune": after,
            "finetune_photos": json.loads(tuned.with_suffix(".json").read_text())["train_images"],
        })
    if args.json:
        Path(args.json).write_text(json.dumps(result, indent=2) + "\n")
        print(f"wrote {args.json}")


if __name__ == "__main__":
    main()
