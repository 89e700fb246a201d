#!/usr/bin/env bash
# Re-locks every dependency from pyproject.toml into uv.lock and writes the two hashed exports
# that scripts/setup.sh installs: requirements/run.txt (the tool) and requirements/test.txt
# (with the test and ray extras). uv itself comes from requirements/uv.txt, hashed too.
#   bash scripts/lock.sh            keep every locked version that still satisfies pyproject.toml
#   bash scripts/lock.sh --upgrade  move every package to its newest allowed version (measure first)
#   bash scripts/lock.sh --check    exit 1 when uv.lock or an export no longer matches pyproject.toml
set -euo pipefail
cd "$(dirname "$0")/.."

tools="$(mktemp -d)"
trap 'rm -rf "$tools"' EXIT
python3 -m venv "$tools"
"$tools/bin/python" -m pip install --quiet --require-hashes --no-deps -r requirements/uv.txt
uv="$tools/bin/uv"

export_lock() {  # NAME, then uv export's selection of extras and groups
  local name="$1"
  shift
  "$uv" export --quiet --frozen --no-emit-project --format requirements-txt --no-header "$@" \
    --output-file "requirements/$name.txt"
}

if [ "${1:-}" = "--check" ]; then
  "$uv" lock --check --python 3.11
  checked="$(mktemp -d)"
  cp requirements/run.txt requirements/test.txt "$checked/"
  export_lock run --no-dev --group build
  export_lock test --no-dev --group build --extra dev --extra ray
  for name in run test; do
    if ! cmp -s "requirements/$name.txt" "$checked/$name.txt"; then
      cp "$checked/$name.txt" "requirements/$name.txt"
      echo "requirements/$name.txt is not the export of uv.lock: run bash scripts/lock.sh" >&2
      exit 1
    fi
  done
  echo "uv.lock and requirements/*.txt match pyproject.toml"
  exit 0
fi

"$uv" lock --python 3.11 "$@"
export_lock run --no-dev --group build
export_lock test --no-dev --group build --extra dev --extra ray
