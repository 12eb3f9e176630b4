#!/usr/bin/env bash
# fresh_debian.sh - checks the README's promise that its two commands do everything on a
# fresh Debian machine, where the usual machines here already have most of what they install.
#
# It makes a minimal Debian root (debootstrap --variant=minbase: no compiler, no node, no
# make; Debian 12 "bookworm" unless --suite names another, e.g. trixie), puts a clone of this
# repository's HEAD at /work/main in it and a read-only copy of ../shared beside it, as CI
# lays them, and runs inside it (chroot):
#   apt-get install make      (the one thing a minimal system lacks to start)
#   make run                  (the README's first command)
#   CI=true bash .ci/run      (the second, as CI calls it; skipped with --run-only)
# and prints each one's exit code. Exit 0 when all passed.
#
# Root only (debootstrap, chroot, mounts); needs the Debian mirror and the npm registry. The
# host's own CA certificates (/usr/local/share/ca-certificates) are copied in, so that a proxy
# the host trusts is trusted inside too. About 5 minutes with --run-only, 40 with the tests,
# on 2 cores. Not part of `make test`: it installs a system.
#
# usage: tests/tools/fresh_debian.sh [--run-only] [--suite NAME] [DIR]
#        DIR: a new folder, default /var/tmp/lodpipe-fresh-debian; it is left for inspection,
#        its mounts undone; each step's log is DIR.STEP.log beside it
set -euo pipefail

run_only=0
suite=bookworm
dir=/var/tmp/lodpipe-fresh-debian
while [ $# -gt 0 ]; do
  case "$1" in
    --run-only) run_only=1 ;;
    --suite) [ $# -gt 1 ] || { echo "fresh_debian.sh: --suite needs a name" >&2; exit 1; }; suite=$2; shift ;;
    -*) echo "fresh_debian.sh: unknown option $1" >&2; exit 1 ;;
    *) dir=$1 ;;
  esac
  shift
done

repo=$(cd "$(dirname "$0")/../.." && pwd)
shared=$(cd "$repo/../shared" 2>/dev/null && pwd) || { echo "fresh_debian.sh: no ../shared beside $repo" >&2; exit 1; }
[ "$(id -u)" = 0 ] || { echo "fresh_debian.sh: must run as root (debootstrap, chroot, mounts)" >&2; exit 1; }
[ ! -e "$dir" ] || { echo "fresh_debian.sh: $dir exists; give a new folder (the point is a fresh system)" >&2; exit 1; }
command -v debootstrap >/dev/null || DEBIAN_FRONTEND=noninteractive apt-get install -y -qq debootstrap >/dev/null

mounted=()
undo_mounts() {
  local i
  for ((i = ${#mounted[@]} - 1; i >= 0; i--)); do umount -R "${mounted[i]}" 2>/dev/null || umount -l "${mounted[i]}" || true; done
}
trap undo_mounts EXIT

echo "== debootstrap $suite (minbase) into $dir"
debootstrap --variant=minbase "$suite" "$dir" http://deb.debian.org/debian >"$dir.debootstrap.log" 2>&1 \
  || { echo "fresh_debian.sh: debootstrap failed, see $dir.debootstrap.log" >&2; exit 1; }
cat >"$dir/etc/apt/sources.list" <<EOF
deb http://deb.debian.org/debian $suite main
deb http://deb.debian.org/debian $suite-updates main
deb http://deb.debian.org/debian-security $suite-security main
EOF
cp /etc/resolv.conf "$dir/etc/resolv.conf"
if compgen -G '/usr/local/share/ca-certificates/*.crt' >/dev/null; then
  # (the bundle is made when make deps installs ca-certificates, whose set-up reads this folder)
  mkdir -p "$dir/usr/local/share/ca-certificates"
  cp /usr/local/share/ca-certificates/*.crt "$dir/usr/local/share/ca-certificates/"
fi

mkdir -p "$dir/work"
git clone -q "$repo" "$dir/work/main"
cp -a "$shared" "$dir/work/shared"
chmod -R a-w "$dir/work/shared"

# what a booted system has mounted (its /tmp stays a folder on disk, as on these machines); the
# root itself is made a mount point first, as a booted system's is: without that, `unshare -m`
# inside cannot work and the test of a full disk (a 16 KiB tmpfs) skips itself
mount_in() { # TARGET MOUNT-ARGUMENTS...
  local target=$1; shift
  mount "$@" "$target" || { echo "fresh_debian.sh: cannot mount $target" >&2; exit 1; }
  mounted+=("$target")
}
mount_in "$dir" --bind "$dir"
mount_in "$dir/proc" -t proc proc
mount_in "$dir/sys" -t sysfs sys
mount_in "$dir/dev" --rbind /dev

# inside: a clean environment, as a new login would have, plus the host's CA variables when it
# sets them (they name the system bundle, which the copy above refreshed inside: node's own
# bundle does not hold a proxy's CA)
ca_env=()
for v in NODE_EXTRA_CA_CERTS SSL_CERT_FILE SSL_CERT_DIR; do
  [ -z "${!v:-}" ] || ca_env+=("$v=${!v}")
done
inside() {
  chroot "$dir" /usr/bin/env -i HOME=/root PATH=/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin \
    LANG=C.UTF-8 DEBIAN_FRONTEND=noninteractive "${ca_env[@]}" "$@"
}
step() {
  local name=$1; shift
  local t0=$SECONDS rc=0
  echo "== $name"
  inside /bin/bash -c "$*" >"$dir.$name.log" 2>&1 || rc=$?
  echo "   exit $rc after $((SECONDS - t0)) s; log $dir.$name.log"
  tail -n 3 "$dir.$name.log" | sed 's/^/   | /'
  return "$rc"
}
step make-installed 'apt-get update -qq && apt-get install -y -qq make' || exit 1
inside /bin/bash -c 'echo "   node before make run: $(command -v node || echo none)"'
step make-run 'cd /work/main && make run' || exit 1
inside /bin/bash -c 'echo "   node after: $(node --version), npm $(npm --version), gcc $(gcc -dumpfullversion)"'
[ "$run_only" = 1 ] || step ci-run 'cd /work/main && CI=true bash .ci/run' || exit 1
