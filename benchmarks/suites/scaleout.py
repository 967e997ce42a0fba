"""Suite ``scaleout``: what Ray buys on this machine, and what a cluster would cost.

1. Sweep: the same 24 cells (3 scenarios x DON with the position and the learned
   controller x 4 seeds, 150 frames each) run as `imimic eval` runs them without a
   backend (one process, one env per configuration) and as Ray tasks on a local Ray of
   this machine's CPUs, started inside the timed region, as `imimic eval --backend ray`
   does. Twice: on clips not rendered yet
   (each backend with an empty clip cache of its own: a sweep over a fresh pool), and
   again with both caches warm. Per-seed rows compared for equality.
2. Rendering: 8 clips of 150 frames rendered into empty caches through
   `clips.cache.warm_clip`, here and as Ray tasks (`imimic cache --warm`).

From these, a cost model: seconds per cell and per rendered clip on one core, the
parallel efficiency measured here, and the arithmetic for 10,000 clips on N nodes.
"""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

from imimic_gym.backends import fan_out
from imimic_gym.bench import machine
from imimic_gym.clips.cache import warm_clip
from imimic_gym.clips.scenarios import get_scenario
from imimic_gym.suite import RunConfig, run_config, summarise
from imimic_gym.sweep import Cell, run_sweep, summaries

SCENARIOS = ("exp2-servo", "exp3-forearm-low", "default")
CONTROLLERS = ("position", "learned")
FIRST_SEED = 8100  # speed only: no figure of accuracy is read from these clips
TARGET_RATIO = 0.6
PARTS = ("sweep", "render")


def _cells(seeds: int) -> list[Cell]:
    return [Cell(s, "don", c, FIRST_SEED + k) for s in SCENARIOS for c in CONTROLLERS
            for k in range(seeds)]


def _serial(seeds: int, cache: str) -> tuple[float, list]:
    """`imimic eval` as it runs without a backend: one env per configuration."""
    os.environ["IMIMIC_CACHE_DIR"] = cache
    configs = [RunConfig(s, "don", c, tuple(range(FIRST_SEED, FIRST_SEED + seeds)))
               for s in SCENARIOS for c in CONTROLLERS]
    start = time.perf_counter()
    results = [summarise(config, run_config(config)) for config in configs]
    return time.perf_counter() - start, results


def _on_ray(cells: list[Cell], cache: str, address: str | None) -> tuple[float, list]:
    os.environ["IMIMIC_CACHE_DIR"] = cache  # Ray's workers get it when the sweep joins
    start = time.perf_counter()
    result = run_sweep(cells, backend="ray", address=address, progress=False)
    seconds = time.perf_counter() - start
    if result.failures:
        raise RuntimeError(f"cells failed: {result.failures}")
    return seconds, summaries(cells, result.rows)


@contextlib.contextmanager
def running_ray(cache: str) -> Iterator[None]:
    """A local Ray of this machine's CPUs started beforehand (``ray start --head``), as a
    user keeps one for several sweeps; stopped afterwards."""
    ray = Path(sys.executable).with_name("ray")
    env = {**os.environ, "IMIMIC_CACHE_DIR": cache}
    subprocess.run([str(ray), "start", "--head", f"--num-cpus={os.cpu_count()}",
                    "--include-dashboard=false", "--disable-usage-stats"], check=True,
                   env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        yield
    finally:
        subprocess.run([str(ray), "stop", "--force"], check=False,
                       stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def sweep(quick: bool) -> dict[str, Any]:
    """A protocol-sized sweep (40 seeds a configuration: 240 cells) on clips not rendered
    yet and again cached, then the issue's minimum of 24 cells (4 seeds), cached; each
    in one process, on a Ray the sweep starts, and on a Ray already running."""
    big, small = (2, 1) if quick else (40, 4)
    out: dict[str, Any] = {"frames": get_scenario(SCENARIOS[0]).n_frames,
                           "scenarios": list(SCENARIOS), "controllers": list(CONTROLLERS),
                           "first_seed": FIRST_SEED, "runs": []}
    plan = ((big, "cold"), (big, "warm"), (small, "warm"))
    with contextlib.ExitStack() as stack:
        here, started, running = (stack.enter_context(tempfile.TemporaryDirectory())
                                  for _ in range(3))
        for seeds, cache in plan:
            cells = _cells(seeds)
            serial, local_rows = _serial(seeds, here)
            run: dict[str, Any] = {"cells": len(cells), "seeds": seeds, "cache": cache,
                                   "serial_s": serial}
            for name, folder in (("started", started), ("running", running)):
                with running_ray(folder) if name == "running" else contextlib.nullcontext():
                    seconds, ray_rows = _on_ray(cells, folder,
                                                "auto" if name == "running" else None)
                run[name] = {"ray_s": seconds, "ratio": seconds / serial,
                             "identical": local_rows == ray_rows,
                             "met": seconds / serial <= TARGET_RATIO}
                print(f"sweep of {len(cells)} cells, {cache} cache, Ray {name}: serial "
                      f"{serial:.1f} s, Ray {seconds:.1f} s, ratio {seconds / serial:.2f}, "
                      f"identical {local_rows == ray_rows}", flush=True)
            out["runs"].append(run)
    return out


def render_clips(quick: bool) -> dict[str, Any]:
    spec = get_scenario("default")
    specs = [spec.replace(seed=FIRST_SEED + k) for k in range(2 if quick else 8)]
    out: dict[str, Any] = {"clips": len(specs), "frames": spec.n_frames,
                           "size": [spec.height, spec.width]}
    for backend in ("local", "ray"):
        with tempfile.TemporaryDirectory() as cache:
            os.environ["IMIMIC_CACHE_DIR"] = cache
            start = time.perf_counter()
            done = list(fan_out(warm_clip, specs, backend=backend))
            out[f"{backend}_s"] = time.perf_counter() - start
            if not all(o.ok for o in done):
                raise RuntimeError([o.error for o in done if not o.ok])
            out["clip_bytes"] = done[0].value["bytes"]
        print(f"rendering {len(specs)} clips, {backend}: {out[f'{backend}_s']:.1f} s")
    return out


def run(args: Any) -> dict[str, Any]:
    parts = args.parts or PARTS
    data: dict[str, Any] = {"machine": machine(), "quick": bool(args.quick),
                            "target_ratio": TARGET_RATIO}
    saved = os.environ.get("IMIMIC_CACHE_DIR")
    try:
        for part in parts:
            data[part] = {"sweep": sweep, "render": render_clips}[part](args.quick)
    finally:
        if saved is None:
            os.environ.pop("IMIMIC_CACHE_DIR", None)
        else:
            os.environ["IMIMIC_CACHE_DIR"] = saved
    return data


def render(data: dict[str, Any]) -> str:
    m, cores = data["machine"], data["machine"]["cores"]
    quick = ("**A quick run (`--quick`): a few cells; not the reported figures.**\n"
             if data.get("quick") else "")
    out = [f"""## Scale-out on Ray (suite `scaleout`)

Command: `.venv/bin/python benchmarks/run.py scaleout` (JSON:
`benchmarks/results/scaleout.json`; this section is rendered from it). Machine:
{m['cpu']}, {cores} cores; Ray is a local one of {cores} CPUs, started inside the timed
region. Wall times of one run each; the ratio is Ray's time over the serial time of the
same cells in the same run (target: at most {data['target_ratio']}).
{quick}"""]
    s = data.get("sweep")
    if s:
        def verdict(run: dict[str, Any]) -> str:
            return (f"{run['ray_s']:.1f} | {run['ratio']:.2f} "
                    f"{'**met**' if run['met'] else '**missed**'}")

        rows = [f"| {r['cells']} | {r['cache']} | {r['serial_s']:.1f} | "
                f"{verdict(r['started'])} | {verdict(r['running'])} | "
                f"{'yes' if r['started']['identical'] and r['running']['identical'] else '**no**'}"
                " |" for r in s["runs"]]
        warm = [r for r in s["runs"] if r["cache"] == "warm"]
        per_cell = warm[0]["serial_s"] / warm[0]["cells"]
        cores = data["machine"]["cores"]
        overhead = [r["started"]["ray_s"] - r["serial_s"] / cores for r in warm]
        out.append(f"""### Sweeps

{', '.join(f'`{x}`' for x in s['scenarios'])} x DON with the
{' and the '.join(s['controllers'])} controller x seeds from {s['first_seed']},
{s['frames']} frames each: `imimic eval --scenario ... --controller position learned
--episodes K --first-seed {s['first_seed']} --backend ray` against the same command
without `--backend` (one process, one env per configuration). "Started": the command
starts a local Ray and stops it (its start is timed); "running": a local Ray started
beforehand with `ray start --head` and joined with `--address auto`, as one kept for
several sweeps. "cold": the clips not rendered yet (each run its own empty cache), as in
a sweep over a fresh pool. Target: Ray's time at most {data['target_ratio']} of the serial.

| cells | clips | serial (s) | Ray started (s) | ratio | Ray running (s) | ratio | identical |
|---|---|---|---|---|---|---|---|
""" + "\n".join(rows) + f"""

A cell on cached clips costs {per_cell:.2f} s here. A Ray the sweep starts took
{' and '.join(f'{o:.1f} s' for o in overhead)} more than a perfect split of the serial
time over {cores} cores on the cached runs: its start and each worker's imports (torch
and the policy for the learned controller) are paid once per sweep, so a sweep of 24 such
cheap cells cannot gain from it on {cores} cores, and the bigger the sweep the nearer the
ratio comes to 1 / cores.""")
    r = data.get("render")
    if r:
        per_clip = r["local_s"] / r["clips"]
        efficiency = r["local_s"] / (cores * r["ray_s"])
        mb = r["clip_bytes"] / 1e6
        nodes = (1, 10, 50)
        hours = [10_000 * per_clip / (n * cores * efficiency) / 3600 for n in nodes]
        out.append(f"""### Rendering clips, and the cost of 10,000

{r['clips']} clips of {r['frames']} frames at {r['size'][1]}x{r['size'][0]} (RGB, depth and
truth; {mb:.0f} MB each in the cache): {r['local_s']:.1f} s here, one after another
({per_clip:.2f} s a clip), {r['ray_s']:.1f} s as Ray tasks on {cores} CPUs: a parallel
efficiency of {efficiency:.2f} (serial time / (CPUs x Ray time)).

At {per_clip:.2f} s a clip per CPU and that efficiency, 10,000 clips take
10,000 x {per_clip:.2f} / (N x {cores} x {efficiency:.2f}) s on N nodes like this one:
{', '.join(f'{h:.2f} h on {n}' for h, n in zip(hours, nodes, strict=True))}, and
{10_000 * mb / 1e3:.0f} GB of cache in all (each node's own cache holds the clips it
rendered, unless `--cache-dir` names a shared folder; raise `IMIMIC_CACHE_MAX_GB` to
keep them). The efficiency on a real cluster also depends on its network and scheduler;
this machine cannot measure more than one node.""")
    return "\n\n".join(out) + "\n"
