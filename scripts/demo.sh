#!/usr/bin/env bash
# Installs viewslam and records the built-in demo (a synthetic fr2/360_kidnap-style sequence,
# both pipelines) into recordings/demo.rrd, with its report and trajectories beside it.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/setup.sh run
viewslam record "$@"
