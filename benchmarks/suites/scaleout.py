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
    """Clips rendered into empty caches, here and as Ray tasks, at two batch sizes: the
    difference between them is the cost of a clip once the batch is under way, the rest
    the fixed cost of a batch (Ray's start, its workers' imports)."""
    spec = get_scenario("default")
    sizes = (2, 4) if quick else (8, 48)
    out: dict[str, Any] = {"sizes": list(sizes), "frames": spec.n_frames,
                           "size": [spec.height, spec.width], "seconds": {}}
    for backend in ("local", "ray"):
        for count in sizes:
            specs = [spec.replace(seed=FIRST_SEED + k) for k in range(count)]
            with tempfile.TemporaryDirectory() as cache:
                os.environ["IMIMIC_CACHE_DIR"] = cache
                start = time.perf_counter()
                done = list(fan_out(warm_clip, specs, backend=backend))
                seconds = time.perf_counter() - start
                if not all(o.ok for o in done):
                    raise RuntimeError([o.error for o in done if not o.ok])
                out["clip_bytes"] = done[0].value["bytes"]
            out["seconds"][f"{backend}_{count}"] = seconds
            print(f"rendering {count} clips, {backend}: {seconds:.1f} s", flush=True)
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
{m['cpu']}, {cores} cores; Ray is a local one of {cores} CPUs. Wall times of one run each;
the ratio is Ray's time over the serial time of the same cells in the same run (target:
at most {data['target_ratio']}).
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
        warm = sorted((r for r in s["runs"] if r["cache"] == "warm"), key=lambda r: r["cells"])
        cores = data["machine"]["cores"]
        per_cell = warm[-1]["serial_s"] / warm[-1]["cells"]
        # Ray's time beyond a perfect split of the serial time, as fixed + per cell.
        extra = [(r["cells"], r["started"]["ray_s"] - r["serial_s"] / cores) for r in warm]
        (n0, e0), (n1, e1) = extra[0], extra[-1]
        extra_per_cell = (e1 - e0) / (n1 - n0) if n1 > n0 else 0.0
        fixed = e0 - n0 * extra_per_cell
        room = data["target_ratio"] * per_cell - per_cell / cores - extra_per_cell
        needed = f"about {fixed / room:.0f} such cells" if room > 0 else "no number of cells"
        cold = [r for r in s["runs"] if r["cache"] == "cold"]
        cold_text = "; ".join(
            f"a sweep of {r['cells']} cells that renders its clips, as over a fresh pool, "
            f"{'reaches' if r['started']['met'] else 'misses'} it "
            f"({r['started']['ratio']:.2f})" for r in cold)
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

A cell on cached clips costs {per_cell:.2f} s here. Beyond a perfect split of the serial
time over {cores} cores, a Ray the sweep starts took {e0:.1f} s with {n0} cached cells and
{e1:.1f} s with {n1}: about {fixed:.1f} s once (Ray's start and each worker's imports:
torch and the policy for the learned controller; a Ray already running saves only its
own start, since every new job starts its workers) and {1000 * extra_per_cell:.0f} ms a
cell. By that arithmetic a cached sweep of cells this cheap reaches the target from
{needed}; {cold_text}.""")
    r = data.get("render")
    if r:
        small, big = r["sizes"]
        t = r["seconds"]
        serial = (t[f"local_{big}"] - t[f"local_{small}"]) / (big - small)
        on_ray = (t[f"ray_{big}"] - t[f"ray_{small}"]) / (big - small)
        fixed = t[f"ray_{small}"] - small * on_ray
        efficiency = serial / (cores * on_ray)
        mb = r["clip_bytes"] / 1e6
        nodes = (1, 10, 50)
        hours = [(fixed + 10_000 * serial / (n * cores * efficiency)) / 3600 for n in nodes]
        rows = [f"| {count} | {t[f'local_{count}']:.1f} | {t[f'ray_{count}']:.1f} |"
                for count in (small, big)]
        out.append(f"""### Rendering clips, and the cost of 10,000

Clips of {r['frames']} frames at {r['size'][1]}x{r['size'][0]} (RGB, depth and truth;
{mb:.0f} MB each in the cache) rendered into empty caches, here one after another and as
Ray tasks on {cores} CPUs (`imimic cache --warm ... --backend ray`), in batches of
{small} and {big}:

| clips | here (s) | Ray (s) |
|---|---|---|
""" + "\n".join(rows) + f"""

Between the two batches a clip costs {serial:.2f} s here and {on_ray:.2f} s on Ray: a
parallel efficiency of {efficiency:.2f} once a batch is under way (the time here over
{cores} x the time on Ray); a batch on Ray also pays {fixed:.1f} s once (Ray's start, the
workers' imports). So 10,000 clips take {fixed:.0f} + 10,000 x {serial:.2f} / (N x
{cores} x {efficiency:.2f}) s on N nodes like this one: {', '.join(
    f'{h:.2f} h on {n}' for h, n in zip(hours, nodes, strict=True))}, and
{10_000 * mb / 1e3:.0f} GB of cache in all (each node's own cache holds the clips it
rendered, unless `--cache-dir` names a shared folder; raise `IMIMIC_CACHE_MAX_GB` to keep
them). A real cluster adds its network and scheduler, which one machine cannot measure.""")
    return "\n\n".join(out) + "\n"
