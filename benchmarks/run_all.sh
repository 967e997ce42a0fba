#!/usr/bin/env bash
# Reruns every benchmark quoted in benchmarks/RESULTS.md and the README.
#   bash benchmarks/run_all.sh        (or: make bench)
# Results land in benchmarks/results/*.json; copy the tables into RESULTS.md.
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${BIN:-.venv/bin}
mkdir -p benchmarks/results
"$BIN/imimic" bench env --json benchmarks/results/env.json
"$BIN/python" benchmarks/oracle_tracking.py --json benchmarks/results/oracle.json
"$BIN/python" benchmarks/step_profile.py --json benchmarks/results/step_profile.json
"$BIN/imimic" bench don --json benchmarks/results/don.json
"$BIN/imimic" eval --scenario exp2-servo default exp3-forearm-none exp3-forearm-low \
    exp3-forearm-high exp1-noisy-fast --estimator don mog2 camshift --episodes 10 \
    --json benchmarks/results/eval.json
"$BIN/imimic" eval --scenario exp2-servo default exp3-forearm-none exp3-forearm-low \
    exp3-forearm-high exp1-noisy-fast --estimator don \
    --episodes 10 --modality depth --json benchmarks/results/eval_depth.json
# Real footage (issue 6): skipped with a message when ../shared/realdata is absent.
"$BIN/python" benchmarks/real_footage.py --json benchmarks/results/real_footage.json
"$BIN/python" benchmarks/write_results.py
