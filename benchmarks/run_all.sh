#!/usr/bin/env bash
# Reruns every benchmark quoted in benchmarks/RESULTS.md and the README.
#   bash benchmarks/run_all.sh        (or: make bench)
# Results land in benchmarks/results/*.json; copy the tables into RESULTS.md.
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${BIN:-.venv/bin}
mkdir -p benchmarks/results
"$BIN/imimic" eval --scenario exp2-servo default exp3-forearm-none exp3-forearm-low \
    exp3-forearm-high exp1-noisy-fast --estimator don don-paper mog2 camshift --episodes 10 \
    --json benchmarks/results/eval.json
"$BIN/imimic" eval --scenario exp2-servo default exp3-forearm-none exp3-forearm-low \
    exp3-forearm-high exp1-noisy-fast --estimator don \
    --episodes 10 --modality depth --json benchmarks/results/eval_depth.json
# Fresh clips, more of them: is the held-out figure a property of seeds 1000-1009?
"$BIN/imimic" eval --scenario exp3-forearm-none exp3-forearm-low exp3-forearm-high \
    --estimator don --episodes 30 --first-seed 2000 --json benchmarks/results/eval_fresh.json
"$BIN/python" benchmarks/don_known_pivot.py --json benchmarks/results/don_known_pivot.json
"$BIN/python" benchmarks/don_error_sources.py --json benchmarks/results/don_error_sources.json
# The runner's suites: the test pool (accuracy, tracking, paper), the shipped CNN (cnn),
# real people (parts that need ../shared/realdata are skipped with a message without it),
# scale-out on Ray, a fresh clone's waits (fresh_clone).
"$BIN/python" benchmarks/run.py all --backend ray
# That the compiled loops (c3f9eeb) left every
# estimate as it was at 0ebd481, the last revision without them.
"$BIN/python" benchmarks/don_same_estimates.py --base 0ebd481 --head c3f9eeb \
    --json benchmarks/results/don_same_estimates.json
"$BIN/imimic" eval --scenario chain-2 chain-3 exp4-hand --estimator don don-paper --episodes 10 \
    --json benchmarks/results/don_links.json
"$BIN/python" benchmarks/don_links_dev_seeds.py --json benchmarks/results/don_links_dev.json
"$BIN/python" benchmarks/write_results.py
