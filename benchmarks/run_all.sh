#!/usr/bin/env bash
# Reruns every benchmark quoted in benchmarks/RESULTS.md and the README: every suite of the
# runner, then RESULTS.md from their JSON.
#   bash benchmarks/run_all.sh        (or: make bench)
# It writes only benchmarks/results/ and RESULTS.md (no checkpoint is retrained).
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${BIN:-.venv/bin}
"$BIN/python" benchmarks/run.py all --backend ray
