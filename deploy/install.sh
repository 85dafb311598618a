#!/usr/bin/env bash
# Install (or uninstall) navd on the robot board. Idempotent: running it again upgrades navd
# and leaves everything else as it is.
#
#   sudo deploy/install.sh [--source DIR_OR_WHEEL] [--prefix /opt/navd]
#   sudo deploy/install.sh --uninstall [--purge]
#
# What it does: creates the system user `navd` (in the dialout group, for the UART), a
# virtual environment under PREFIX/venv with navd and its dependencies, the systemd units
# /etc/systemd/system/navd.service and navd-sensor@.service (one sensor program per device,
# described in /etc/navd/sensors/NAME.env), the default config /etc/navd/navd.toml (never
# overwriting an edited one: a newer default is written beside it as navd.toml.new), the
# state directory /var/lib/navd (maps, numba cache), then enables and starts the service.
# Everything it installed is listed in PREFIX/share/navd/installed, which --uninstall
# reads: it removes those files and nothing else, keeps an edited config and the maps in
# /var/lib/navd (--purge removes those and the user too).
#
# Options:
#   --source PATH     the navd checkout or wheel to install (default: this script's checkout)
#   --prefix DIR      where the virtual environment goes (default /opt/navd)
#   --destdir DIR     stage everything under DIR instead of / (for packaging and tests):
#                     no user is created and systemctl is not called
#   --no-system       do not create the user or call systemctl
#   --pip-args "..."  extra arguments for pip (e.g. a local index, --no-deps)
#   --python PATH     the Python (>= 3.11) for the virtual environment (default python3)
set -euo pipefail

here=$(cd "$(dirname "$0")" && pwd)
source_path=$(cd "$here/.." && pwd)
prefix=/opt/navd
destdir=""
system=1
pip_args=""
python=python3
action=install
purge=0

die() { echo "install.sh: $*" >&2; exit 1; }
say() { echo "install.sh: $*"; }

while [[ $# -gt 0 ]]; do
  case "$1" in
    --source) source_path=$2; shift 2 ;;
    --prefix) prefix=$2; shift 2 ;;
    --destdir) destdir=${2%/}; system=0; shift 2 ;;
    --no-system) system=0; shift ;;
    --pip-args) pip_args=$2; shift 2 ;;
    --python) python=$2; shift 2 ;;
    --uninstall) action=uninstall; shift ;;
    --purge) purge=1; shift ;;
    -h|--help) sed -n '2,25p' "$0"; exit 0 ;;
    *) die "unknown option '$1' (see --help)" ;;
  esac
done

[[ $prefix == /* ]] || die "--prefix must be an absolute path, got '$prefix'"
if [[ $system == 1 && $(id -u) != 0 ]]; then
  die "run as root (sudo), or stage with --destdir DIR / --no-system"
fi

root="$destdir"
venv="$prefix/venv"
conf_dir=/etc/navd
unit=/etc/systemd/system/navd.service
sensor_unit=/etc/systemd/system/navd-sensor@.service
sensors_dir=$conf_dir/sensors
state_dir=/var/lib/navd
share="$prefix/share/navd"
manifest="$share/installed"
default_copy="$share/navd.toml.default"

install_navd() {
  [[ -e $source_path ]] || die "--source $source_path does not exist"
  local shipped_config="$here/../config/navd.toml"
  [[ -f $shipped_config ]] || die "default config $shipped_config is missing"
  "$python" -c 'import sys; sys.exit(sys.version_info < (3, 11))' \
    || die "$python is older than Python 3.11"

  if [[ $system == 1 ]]; then
    getent group dialout >/dev/null || groupadd --system dialout
    if ! getent passwd navd >/dev/null; then
      useradd --system --home-dir "$state_dir" --no-create-home --shell /usr/sbin/nologin \
        --groups dialout --comment "navd navigation daemon" navd
      say "created user navd"
    fi
    # I2C buses (IMUs, magnetometers): the group exists where the board's image made one
    if getent group i2c >/dev/null && ! id -nG navd | grep -qw i2c; then
      usermod --append --groups i2c navd
      say "added navd to the i2c group"
    fi
  fi

  mkdir -p "$root$prefix" "$root$share" "$root$conf_dir" "$root$state_dir" \
    "$root$(dirname "$unit")"

  if [[ ! -x $root$venv/bin/python ]]; then
    "$python" -m venv "$root$venv"
    say "created $venv"
  fi
  # shellcheck disable=SC2086  # pip_args holds several arguments on purpose
  "$root$venv/bin/python" -m pip install --quiet --upgrade $pip_args "$source_path"
  say "installed $("$root$venv/bin/python" -m pip show navd | sed -n 's/^Version: /navd /p')"

  sed "s|/opt/navd|$prefix|g" "$here/navd.service" > "$root$unit.tmp"
  mv "$root$unit.tmp" "$root$unit"
  sed "s|/opt/navd|$prefix|g" "$here/navd-sensor@.service" > "$root$sensor_unit.tmp"
  mv "$root$sensor_unit.tmp" "$root$sensor_unit"
  mkdir -p "$root$sensors_dir"  # NAME.env per device: see navd-sensor@.service

  local config="$root$conf_dir/navd.toml"
  if [[ ! -e $config ]]; then
    install -m 0640 "$shipped_config" "$config"
    say "installed the default config $conf_dir/navd.toml"
  elif ! cmp -s "$config" "$shipped_config"; then
    if [[ -e $root$default_copy ]] && ! cmp -s "$root$default_copy" "$shipped_config"; then
      install -m 0640 "$shipped_config" "$config.new"
      say "kept your $conf_dir/navd.toml; the new default is beside it as navd.toml.new"
    else
      say "kept your $conf_dir/navd.toml"
    fi
  fi
  install -m 0644 "$shipped_config" "$root$default_copy"

  printf '%s\n' "$unit" "$sensor_unit" "$venv" "$default_copy" "$manifest" > "$root$manifest"

  if [[ $system == 1 ]]; then
    chown root:navd "$root$conf_dir" "$root$conf_dir/navd.toml"
    chmod 0750 "$root$conf_dir"
    # The kernels compiled now, as the service's user into the service's cache, so that the
    # first start after an install or upgrade loads them (a start that finds them missing
    # compiles them itself, in a child process, taking a minute or more on the board).
    install -d -o navd -g navd -m 0750 "$state_dir/numba-cache"
    if runuser -u navd -- env NUMBA_CACHE_DIR="$state_dir/numba-cache" "$venv/bin/navd" kernels; then
      say "compiled navd's kernels into $state_dir/numba-cache"
    else
      say "could not compile the kernels now; navd's first start will"
    fi
    systemctl daemon-reload
    systemctl enable navd.service
    if systemctl is-active --quiet navd.service; then
      systemctl restart navd.service
    else
      systemctl start navd.service
    fi
    say "navd is $(systemctl is-active navd.service); follow it with: journalctl -u navd -f"
  else
    say "staged in ${root:-/} (no user created, systemctl not called)"
  fi
}

uninstall_navd() {
  [[ -f $root$manifest ]] || die "nothing to uninstall: $manifest not found"
  if [[ $system == 1 ]]; then
    systemctl disable --now 'navd-sensor@*.service' 2>/dev/null || true
    systemctl disable --now navd.service 2>/dev/null || true
  fi
  local config="$root$conf_dir/navd.toml"
  if [[ -e $config && -e $root$default_copy ]] && cmp -s "$config" "$root$default_copy"; then
    rm -f "$config"  # unchanged default: ours to remove
  elif [[ -e $config && $purge == 0 ]]; then
    say "kept your edited $conf_dir/navd.toml (--purge removes it)"
  fi
  [[ $purge == 1 ]] && rm -f "$config" "$config.new"
  while read -r path; do
    [[ -n $path && $path == /* ]] || continue
    rm -rf "${root:?}$path"
  done < "$root$manifest"
  rmdir "$root$share" "$root$prefix/share" "$root$prefix" 2>/dev/null || true
  if [[ $purge == 1 ]]; then
    rm -rf "${root:?}$sensors_dir"
  else
    rmdir "$root$sensors_dir" 2>/dev/null || say "kept your $sensors_dir (--purge removes it)"
  fi
  rmdir "$root$conf_dir" 2>/dev/null || true
  if [[ $purge == 1 ]]; then
    rm -rf "${root:?}$state_dir"
    if [[ $system == 1 ]] && getent passwd navd >/dev/null; then
      userdel navd
    fi
  else
    rmdir "$root$state_dir" 2>/dev/null || say "kept $state_dir (maps; --purge removes it)"
  fi
  if [[ $system == 1 ]]; then
    systemctl daemon-reload
  fi
  say "uninstalled"
}

if [[ $action == install ]]; then install_navd; else uninstall_navd; fi
