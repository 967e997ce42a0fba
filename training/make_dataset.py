"""Render a labelled-arm dataset and write its COCO-keypoints annotation files.

Each run writes ``<out>/<name>_train.json`` and ``<out>/<name>_test.json``, ``<out>``
being ``runs/data`` in the working directory unless ``--out`` says otherwise. The
defaults make the paper's 300-image split: 56 clips x 4 frames = 224 training images and
19 clips x 4 = 76 test images. The shipped files were made with the defaults, and are
replaced only when asked, from the repository's root:
    .venv/bin/python training/make_dataset.py --links 1 --out imimic_gym/data/annotations
    .venv/bin/python training/make_dataset.py --links 2 --out imimic_gym/data/annotations
Bigger training sets for the learning curve: ``--train-clips 750 --name arm1_3000``.
``--backend ray [--address ADDR]`` renders one clip per Ray task (the same files).
``--randomise`` draws each clip's look at random (clothing and skin colours, backdrop,
light, camera height, tilt, distance and place: `dataset.randomised_spec`), for a CNN
meant for footage beyond our renderer: ``--randomise --train-clips 150 --name arm2_random
--links 2``.
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

from imimic_gym.backends import BACKENDS, BackendError
from imimic_gym.cli.common import at_least
from imimic_gym.clips.annotations import write_annotations
from imimic_gym.clips.dataset import DEFAULT_ANNOTATIONS, IMAGES_PER_CLIP, generate_arms

# Seed blocks: training clips, test clips; all far from the env's clip seeds (0-1010).
TRAIN_SEEDS, TEST_SEEDS = 20_000, 60_000
# In the working directory, beside the training scripts' runs: the package's own folder
# holds the shipped dataset, which a trial run must not replace by accident.
DEFAULT_OUT = "runs/data"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--links", type=int, choices=(1, 2), default=1,
                        help="moving links of the demonstrator (default: %(default)s)")
    parser.add_argument("--train-clips", type=at_least(0), default=56,
                        help=f"training clips, {IMAGES_PER_CLIP} images each; 0 writes no "
                             "training file (default: %(default)s)")
    parser.add_argument("--test-clips", type=at_least(0), default=19,
                        help=f"test clips, {IMAGES_PER_CLIP} images each; 0 writes no test "
                             "file (default: %(default)s)")
    parser.add_argument("--name", default=None,
                        help="file stem (default: arm<links>, arm<links>_random with "
                             "--randomise); writes <name>_train.json and <name>_test.json")
    parser.add_argument("--out", default=DEFAULT_OUT,
                        help="output folder (default: %(default)s in the working directory); "
                             "the shipped dataset, imimic_gym/data/annotations, is written "
                             "only when --out names it")
    parser.add_argument("--randomise", action="store_true",
                        help="draw every clip's look at random (domain randomisation); "
                             "default: the shipped dataset's plain variation")
    parser.add_argument("--backend", default="local", choices=BACKENDS,
                        help="render here (default) or one Ray task per clip (pip install "
                             "'.[ray]' in a clone)")
    parser.add_argument("--address", default=None, metavar="ADDR",
                        help="--backend ray: a cluster (default: the Ray that `ray start` "
                             "runs here, else a new local one)")
    args = parser.parse_args()
    if args.train_clips == args.test_clips == 0:
        parser.error("--train-clips and --test-clips are both 0: nothing to write")
    name = args.name or f"arm{args.links}{'_random' * args.randomise}"
    offset = 10_000 * (args.links - 1)
    splits = [(split, clips, first) for split, clips, first in (
        ("train", args.train_clips, TRAIN_SEEDS), ("test", args.test_clips, TEST_SEEDS))
        if clips]
    if Path(args.out).resolve() == DEFAULT_ANNOTATIONS.resolve():
        files = [f"{name}_{split}.json" for split, _, _ in splits]
        print(f"--out is the package's own dataset folder {DEFAULT_ANNOTATIONS}: writing "
              + ", ".join(f"{file} (replaces the shipped one)"
                          if (DEFAULT_ANNOTATIONS / file).exists() else f"{file} (new)"
                          for file in files))
    for split, clips, first in splits:
        try:
            arms = generate_arms(args.links, clips, first + offset, rng_seed=first + offset,
                                 prefix=f"{name}/{split}", backend=args.backend,
                                 address=args.address, randomise=args.randomise)
        except BackendError as error:
            parser.exit(2, f"make_dataset.py: {error}\n")
        path = f"{args.out}/{name}_{split}.json"
        look = ", randomised" if args.randomise else ""
        write_annotations(path, arms, description=f"imimic_gym rendered arms, {args.links} "
                          f"link(s){look}, {split}: {len(arms)} images")
        print(f"wrote {path} ({len(arms)} images)")


if __name__ == "__main__":
    main()
