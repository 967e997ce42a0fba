"""`imimic cache`: show, clear or fill (here or on Ray) the cache of rendered clips."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from imimic_gym.cli.common import (
    CommandError,
    add_backend,
    add_clip_seeds,
    check_backend,
    check_writable,
)


def cmd_cache(args: argparse.Namespace) -> int:
    from imimic_gym.clips.cache import cache_limit_bytes, cache_usage, clear_cache

    if args.cache_dir and (args.clear or args.warm):
        check_writable("cache", "--cache-dir", args.cache_dir, folder=True)
    elif args.cache_dir and Path(args.cache_dir).is_file():  # a read-only cache shows fine
        raise CommandError(f"imimic cache: --cache-dir {args.cache_dir} is a file; expected "
                           f"the cache's folder")
    if args.cache_dir:
        os.environ["IMIMIC_CACHE_DIR"] = args.cache_dir  # here and on the Ray workers
    try:
        limit = cache_limit_bytes()
    except ValueError as err:
        print(f"imimic cache: error: {err}", file=sys.stderr)
        return 2
    if args.clear:
        print(f"deleted {clear_cache()} cached clips")
    status = _warm(args) if args.warm else 0
    usage = cache_usage()
    print(f"{usage.directory}: {usage.clips} clips, {usage.bytes / 1e9:.2f} GB "
          f"(bound {limit / 1e9:.1f} GB, IMIMIC_CACHE_MAX_GB)")
    return status


def _warm(args: argparse.Namespace) -> int:
    """Render the clips of ``--warm`` scenarios' seeds that are not cached yet, one task
    each (`clips.cache.warm_clip`), and check each clip that came back where it is visible
    here. Exit code 1 if a clip failed (named, with its error)."""
    from tqdm import tqdm

    from imimic_gym.backends import BackendError, fan_out
    from imimic_gym.clips.cache import check_warmed, warm_clip
    from imimic_gym.clips.scenarios import get_scenario

    check_backend(args, "cache")
    overrides = {"n_frames": args.frames} if args.frames else {}
    specs = [get_scenario(name, **overrides).replace(seed=seed) for name in args.warm
             for seed in range(args.first_seed, args.first_seed + args.episodes)]
    checked, elsewhere, failed = 0, dict[str, int](), list[str]()
    try:
        for outcome in tqdm(fan_out(warm_clip, specs, backend=args.backend,
                                    address=args.address),
                            total=len(specs), desc=f"warming ({args.backend})", unit="clip"):
            spec = outcome.item
            if not outcome.ok:
                failed.append(f"{spec.name} seed {spec.seed}: {outcome.error}")
                continue
            try:
                if check_warmed(spec, outcome.value):
                    checked += 1
                else:
                    host = outcome.value["host"]
                    elsewhere[host] = elsewhere.get(host, 0) + 1
            except ValueError as error:
                failed.append(str(error))
    except BackendError as error:
        raise CommandError(f"imimic cache: {error}") from error
    print(f"{checked} of {len(specs)} clips cached and checked here"
          + "".join(f"; {n} in the cache of node {host}" for host, n in elsewhere.items()))
    for line in failed:
        print(f"  failed: {line}")
    return 1 if failed else 0


def add_cache(sub: argparse._SubParsersAction, names: list[str]) -> None:
    cache = sub.add_parser(
        "cache", help="show, --clear or --warm the cache of rendered clips",
        description="Rendered clips are cached in $IMIMIC_CACHE_DIR (default "
                    "~/.cache/imimic_gym/clips), about 58 MB per 150-frame clip, and the "
                    "least recently used are deleted once they pass $IMIMIC_CACHE_MAX_GB "
                    "(default 20; 'inf' for no bound). Prints the folder, its clips and "
                    "their size. --warm renders the clips an `imimic eval` with the same "
                    "--scenario, --episodes, --first-seed and --frames will read, here or "
                    "as Ray tasks.",
    )
    cache.add_argument("--clear", action="store_true",
                       help="delete every cached clip (they are rendered again when needed)")
    cache.add_argument("--warm", nargs="+", default=None, choices=names, metavar="SCENARIO",
                       help="render these scenarios' clips into the cache")
    add_clip_seeds(cache, "--warm")
    add_backend(cache, "clip rendered")
    cache.add_argument("--cache-dir", default=None, metavar="DIR",
                       help="use this cache folder (sets IMIMIC_CACHE_DIR here and on the "
                            "workers: a path every node shares, or each node's own)")
    cache.set_defaults(func=cmd_cache)
