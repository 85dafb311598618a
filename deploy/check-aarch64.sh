#!/usr/bin/env bash
# Check navd for the robot board (linux aarch64, CPython 3.11) from an x86-64 workstation.
#
#   deploy/check-aarch64.sh [GLIBC]            every runtime dependency has a wheel for the
#                                              board's glibc (default 2.36, Debian 12):
#                                              nothing is compiled on the board
#   deploy/check-aarch64.sh --emulate [GLIBC]  also run navd itself, as the board would, under
#                                              user-mode emulation: an arm64 Debian 12 root
#                                              made from Debian's packages (debootstrap), navd
#                                              and its dependencies installed from their
#                                              aarch64 wheels, then `navd --version`,
#                                              `navd config check` and a short `navd replay`
#                                              run by qemu-aarch64-static with that root's own
#                                              Python. Checks correctness, not speed (the
#                                              numba kernels compile under emulation: minutes).
#
# Both download from the package indexes. --emulate needs debootstrap and qemu-user-static
# (installed with apt when run as root) and keeps the root in $NAVD_ARM64_ROOT (default
# ~/.cache/navd/arm64-bookworm) for the next run. No binfmt_misc registration is needed: the
# emulator is started by hand with -L ROOT, so the root's loader and libraries are used.
set -euo pipefail
emulate=0
if [[ ${1:-} == --emulate ]]; then emulate=1; shift; fi
glibc=${1:-2.36}
python=${PYTHON:-python3}
repo=$(cd "$(dirname "$0")/.." && pwd)
major=${glibc%%.*} minor=${glibc#*.}
platforms=(--platform linux_aarch64 --platform manylinux2014_aarch64)
for ((m = 17; m <= minor; m++)); do platforms+=(--platform "manylinux_${major}_${m}_aarch64"); done
wheel_only=(--only-binary=:all: --implementation cp --python-version 3.11 "${platforms[@]}")
mapfile -t deps < <("$python" - "$repo/pyproject.toml" <<'PY'
import sys, tomllib
print("\n".join(tomllib.load(open(sys.argv[1], "rb"))["project"]["dependencies"]))
PY
)
tmp=$(mktemp -d); trap 'rm -rf "$tmp"' EXIT
failed=0
for dep in "${deps[@]}"; do
  if out=$("$python" -m pip download --quiet --no-deps "${wheel_only[@]}" \
      -d "$tmp/$RANDOM" "$dep" 2>&1); then
    echo "ok      $dep: $(ls "$tmp"/*/ -t | grep -m1 '\.whl$')"
  else
    echo "MISSING $dep: no aarch64 wheel for glibc $glibc: ${out##*ERROR: }"
    failed=1
  fi
done
if ((failed || !emulate)); then exit $failed; fi

# --- emulation -------------------------------------------------------------------------
need() {  # need COMMAND DEBIAN-PACKAGE
  command -v "$1" >/dev/null && return
  if [[ $(id -u) == 0 ]] && command -v apt-get >/dev/null; then
    apt-get install -y -qq "$2" >/dev/null
  else
    echo "FAILED  --emulate needs $1: install the Debian package $2 (as root)" >&2
    exit 2
  fi
}
need debootstrap debootstrap
need qemu-aarch64-static qemu-user-static
root=${NAVD_ARM64_ROOT:-$HOME/.cache/navd/arm64-bookworm}
if [[ ! -x $root/usr/bin/python3.11 ]]; then
  echo "...     making an arm64 Debian 12 root in $root"
  # debootstrap's first stage fetches the packages and unpacks the base system; its second
  # stage would run arm64 maintainer scripts, which needs binfmt_misc. Python needs no
  # configuring, so every fetched package is unpacked instead.
  rm -rf "$root"
  debootstrap --foreign --arch=arm64 --variant=minbase --include=python3 \
    bookworm "$root" http://deb.debian.org/debian >"$tmp/debootstrap.log" 2>&1 \
    || { tail -5 "$tmp/debootstrap.log" >&2; echo "FAILED  debootstrap" >&2; exit 1; }
  for deb in "$root"/var/cache/apt/archives/*.deb; do dpkg-deb -x "$deb" "$root"; done
fi
run() { PYTHONPATH=$tmp/site qemu-aarch64-static -L "$root" "$root/usr/bin/python3.11" "$@"; }
echo "ok      arm64 root: $(run -c 'import platform, sys; print(platform.machine(), "Python", sys.version.split()[0])')"

"$python" -m pip wheel --quiet --no-deps -w "$tmp/wheel" "$repo" >/dev/null 2>&1 \
  || { echo "FAILED  building navd's wheel" >&2; exit 1; }
"$python" -m pip install --quiet --target "$tmp/site" "${wheel_only[@]}" "$tmp"/wheel/navd-*.whl \
  >"$tmp/pip.log" 2>&1 || { tail -5 "$tmp/pip.log" >&2; echo "FAILED  installing" >&2; exit 1; }
echo "ok      installed from aarch64 wheels: $(ls "$tmp/site" | grep -c '\.dist-info$') packages"

echo "ok      navd --version: $(run -m navd --version)"
config=$tmp/navd.toml
run -m navd config dump >"$config"
echo "ok      navd config check: $(run -m navd config check "$config")"

# A short log of a robot turning in a 6 m x 4 m room: 40 FLASER scans of 181 beams.
"$python" - "$tmp/room.clf" <<'PY'
import math, sys
half_x, half_y = 3.0, 2.0
with open(sys.argv[1], "w") as log:
    for i in range(40):
        x, y, yaw = -1.0 + 0.05 * i, 0.2 * math.sin(0.1 * i), 0.03 * i
        ranges = []
        for b in range(181):
            a = yaw - math.pi / 2 + math.pi * b / 180
            dx, dy = math.cos(a), math.sin(a)
            tx = ((half_x if dx > 0 else -half_x) - x) / dx if abs(dx) > 1e-9 else math.inf
            ty = ((half_y if dy > 0 else -half_y) - y) / dy if abs(dy) > 1e-9 else math.inf
            ranges.append(f"{min(tx, ty):.3f}")
        pose = f"{x:.4f} {y:.4f} {yaw:.4f}"
        log.write(f"FLASER 181 {' '.join(ranges)} {pose} {pose} {100.0 + 0.1 * i:.3f} arm 0\n")
PY
start=$(date +%s)
run -m navd replay "$tmp/room.clf" --out "$tmp/replay" --quiet >"$tmp/replay.log" 2>&1 \
  || { tail -5 "$tmp/replay.log" >&2; echo "FAILED  navd replay" >&2; exit 1; }
# The tracked pose at the last scan against the truth the log was made from.
summary=$(run - "$tmp/replay" <<'PY'
import json, math, sys
out = sys.argv[1]
s = json.load(open(f"{out}/summary.json"))
t, x, y, _z, _qx, _qy, qz, qw = map(float, open(f"{out}/trajectory.tum").read().split("\n")[-2].split())
yaw = 2 * math.atan2(qz, qw)
i = 39
err_m = math.hypot(x - (-1.0 + 0.05 * i), y - 0.2 * math.sin(0.1 * i))
err_deg = math.degrees(abs(math.remainder(yaw - 0.03 * i, math.tau)))
ok = s["scans"] == 40 and err_m < 0.10 and err_deg < 2.0
print(("ok" if ok else "FAILED") + f"      navd replay: {s['scans']} scans, {s['matched']} matched, "
      f"map {s['map_cells'][0]} x {s['map_cells'][1]} cells, last pose {100 * err_m:.1f} cm "
      f"and {err_deg:.2f} deg from the truth")
sys.exit(0 if ok else 1)
PY
) || { echo "$summary"; exit 1; }
echo "$summary ($(($(date +%s) - start)) s under emulation)"
