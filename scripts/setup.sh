#!/usr/bin/env bash
# Installs what viewslam needs on a fresh Debian machine with Python 3.11 into ./.venv.
# Usage: source scripts/setup.sh LOCK [DEBIAN_PACKAGES...]
#   LOCK: which export of uv.lock to install: "run" (the tool) or "test" (with the test and ray
#   extras); both are written by scripts/lock.sh
#   DEBIAN_PACKAGES: system packages wanted beyond libusb-1.0-0 (e.g. xvfb)
# Missing Debian packages are installed with apt-get when running as root; otherwise the exact
# command is printed (open3d then falls back to the libusb shipped by PyPI's libusb-package).
set -euo pipefail

repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
lock="${1:?usage: source scripts/setup.sh run|test [DEBIAN_PACKAGES...]}"
shift || true
wanted=(libusb-1.0-0 "$@")

missing=()
for package in "${wanted[@]}"; do
  dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed" || missing+=("$package")
done

python="${PYTHON:-python3}"
if ! "$python" -c 'import ensurepip, venv' 2>/dev/null; then
  missing+=("python3-venv")
fi

if [ ${#missing[@]} -gt 0 ]; then
  if [ "$(id -u)" = "0" ] && command -v apt-get >/dev/null; then
    echo "viewslam setup: installing Debian packages: ${missing[*]}"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${missing[@]}" >/dev/null
  else
    echo "viewslam setup: missing Debian packages; install them with:"
    echo "  sudo apt-get install -y ${missing[*]}"
  fi
fi

if ! "$python" -c 'import sys; sys.exit(sys.version_info < (3, 11))'; then
  echo "viewslam setup: Python >= 3.11 is required ($("$python" --version 2>&1) found)" >&2
  exit 1
fi

if [ ! -x "$repo/.venv/bin/python" ]; then
  "$python" -m venv "$repo/.venv"
fi
# Every dependency comes from the lock (exact versions, checked by hash); the project itself is
# then installed on top without resolving anything.
"$repo/.venv/bin/python" -m pip install --quiet --require-hashes --no-deps -r "$repo/requirements/$lock.txt"
"$repo/.venv/bin/python" -m pip install --quiet --no-deps --no-build-isolation -e "$repo"
export PATH="$repo/.venv/bin:$PATH"
