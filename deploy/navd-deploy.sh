#!/usr/bin/env bash
# From a workstation: push navd to a robot over ssh, sync its config both ways, run one-shot
# commands there. The robot needs ssh access with sudo rights and Python >= 3.11.
#
#   deploy/navd-deploy.sh push HOST [CONFIG]    build a wheel, copy it with deploy/ and install
#                                               (CONFIG, checked locally first, becomes
#                                               /etc/navd/navd.toml)
#   deploy/navd-deploy.sh push-config HOST FILE check FILE locally, install it, reload navd
#   deploy/navd-deploy.sh pull-config HOST [DEST]  copy the robot's config back
#                                               (default DEST: config/robots/HOST.toml)
#   deploy/navd-deploy.sh run HOST -- ARGS...   run `navd ARGS...` on the robot as user navd
#
# HOST is anything ssh accepts (user@robot.local, an ssh_config alias). NAVD_SSH and
# NAVD_SCP override the ssh and scp commands.
set -euo pipefail

ssh_cmd=${NAVD_SSH:-ssh}
scp_cmd=${NAVD_SCP:-scp}
here=$(cd "$(dirname "$0")" && pwd)
repo=$(cd "$here/.." && pwd)
navd_local=${NAVD_LOCAL:-"$repo/.venv/bin/navd"}
remote_tmp=/tmp/navd-deploy

die() { echo "navd-deploy: $*" >&2; exit 1; }
usage() { sed -n '2,17p' "$0"; exit 2; }

check_config() {
  [[ -f $1 ]] || die "config file $1 does not exist"
  # Keys and values only: the files it names (maps, masks) are the robot's, not this machine's.
  "$navd_local" config check --keys-only "$1" >/dev/null \
    || die "$1 is not a valid navd config (see above)"
}

push_config() {  # HOST FILE
  check_config "$2"
  $scp_cmd "$2" "$1:$remote_tmp.navd.toml"
  $ssh_cmd "$1" "sudo install -o root -g navd -m 0640 $remote_tmp.navd.toml /etc/navd/navd.toml \
    && rm -f $remote_tmp.navd.toml && (sudo systemctl reload navd || true)"
}

[[ $# -ge 2 ]] || usage
command=$1 host=$2
shift 2
case "$command" in
  push)
    [[ $# -le 1 ]] || usage
    if [[ $# == 1 ]]; then check_config "$1"; fi
    dist=$(mktemp -d)
    trap 'rm -rf "$dist"' EXIT
    "${PYTHON:-python3}" -m pip wheel --quiet --no-deps -w "$dist" "$repo"
    wheel=$(cd "$dist" && ls navd-*.whl)
    $ssh_cmd "$host" "rm -rf $remote_tmp && mkdir -p $remote_tmp/config"
    $scp_cmd -r "$dist/$wheel" "$repo/deploy" "$host:$remote_tmp/"
    $scp_cmd "$repo/config/navd.toml" "$host:$remote_tmp/config/navd.toml"
    $ssh_cmd "$host" "sudo $remote_tmp/deploy/install.sh --source $remote_tmp/$wheel"
    if [[ $# == 1 ]]; then push_config "$host" "$1"; fi
    ;;
  push-config)
    [[ $# == 1 ]] || usage
    push_config "$host" "$1"
    ;;
  pull-config)
    [[ $# -le 1 ]] || usage
    dest=${1:-"$repo/config/robots/$host.toml"}
    mkdir -p "$(dirname "$dest")"
    $scp_cmd "$host:/etc/navd/navd.toml" "$dest.part"
    mv "$dest.part" "$dest"
    echo "navd-deploy: $host's config is in $dest"
    ;;
  run)
    [[ ${1:-} == -- ]] && shift
    [[ $# -ge 1 ]] || usage
    $ssh_cmd "$host" "sudo -u navd /opt/navd/venv/bin/navd $(printf '%q ' "$@")"
    ;;
  *) usage ;;
esac
