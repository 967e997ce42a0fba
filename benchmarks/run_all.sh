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
    exp3-forearm-high exp1-noisy-fast --estimator don mog2 camshift --episodes 3 \
    --json benchmarks/results/eval.json
"$BIN/imimic" eval --scenario exp2-servo exp3-forearm-low --estimator don \
    --controller position velocity torque position-hold velocity-hold torque-hold learned \
    --episodes 5 --num-envs 2 --out benchmarks/results/tracking \
    --json benchmarks/results/tracking.json
"$BIN/imimic" eval --paper --json benchmarks/results/paper.json --out benchmarks/results/paper
"$BIN/python" benchmarks/eval_paper_time.py --json benchmarks/results/paper_time.json
"$BIN/python" benchmarks/write_results.py
