#!/usr/bin/env bash
# Installs viewslam with its test extras (and Xvfb + Mesa for the viewer screenshot test) and
# runs the test suite on both cores, a test file to a worker: a module's fixtures (its
# recorded runs) are then made once, not once on each worker.
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/setup.sh test xvfb mesa-vulkan-drivers chromium
python -m pytest -n 2 --dist loadfile "$@"
