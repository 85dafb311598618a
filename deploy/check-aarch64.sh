#!/usr/bin/env bash
# Check that every runtime dependency of navd can be installed on the robot board
# (linux aarch64, CPython 3.11) without compiling: a wheel for the manylinux tags the board's
# glibc accepts (pure-Python packages ship py3-none-any wheels, which every board accepts). Downloads into a temporary folder; needs
# access to the package index.
#
#   deploy/check-aarch64.sh [GLIBC]   GLIBC of the board's OS image, default 2.36 (Debian 12)
set -euo pipefail
glibc=${1:-2.36}
python=${PYTHON:-python3}
repo=$(cd "$(dirname "$0")/.." && pwd)
major=${glibc%%.*} minor=${glibc#*.}
platforms=(--platform linux_aarch64 --platform manylinux2014_aarch64)
for ((m = 17; m <= minor; m++)); do platforms+=(--platform "manylinux_${major}_${m}_aarch64"); done
mapfile -t deps < <("$python" - "$repo/pyproject.toml" <<'PY'
import sys, tomllib
print("\n".join(tomllib.load(open(sys.argv[1], "rb"))["project"]["dependencies"]))
PY
)
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
failed=0
for dep in "${deps[@]}"; do
  if out=$("$python" -m pip download --quiet --no-deps --only-binary=:all: --implementation cp \
      --python-version 3.11 "${platforms[@]}" -d "$tmp/$RANDOM" "$dep" 2>&1); then
    echo "ok      $dep: $(ls "$tmp"/*/ -t | grep -m1 '\.whl$')"
  else
    echo "MISSING $dep: no aarch64 wheel for glibc $glibc: ${out##*ERROR: }"
    failed=1
  fi
done
exit $failed
