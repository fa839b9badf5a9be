#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# The Debian packages (cmake/DebianPackages.cmake) checked as a user gets them (docs/building.md, "Debian packages"):
#   1. cpack -G DEB in the release tree that scripts/build-and-test.sh has built (no second build);
#   2. lintian on the three .deb: any error or warning fails (overrides: packaging/debian/*.lintian-overrides);
#   3. apt-get install of the three packages;
#   4. with the checkout out of reach (a private mount namespace with an empty, mode-0 tmpfs over it): the installed
#      hapticd's --help, `hapticd --dry-run`, `hapticd --criterion CE2 --duration 1`, the config search order
#      (/etc/hapticd over /usr/share/hapticd, $HAPTICD_CONFIG over both, --config over all; /etc/hapticd/NAME.toml
#      over hapticd.toml for --instance NAME), and
#      `systemd-analyze verify` of the installed unit and of an instance of its template (hapticd@left.service);
#   5. the outside projects tests/packaging/consumer (find_package(hapticopt)) and client_consumer
#      (find_package(hapticd)) against /usr;
#   6. apt-get purge of the three, then no file of theirs is left. The user and group hapticd stay (Debian never
#      removes a system user); this script removes them afterwards when it created them.
# Needs root (it installs packages) and the packages of scripts/install-deps.sh.
# Usage: scripts/test-debian-packages.sh [release build dir, default build/release]
set -euo pipefail
cd "$(dirname "${BASH_SOURCE[0]}")/.."
root=$PWD
build=$(realpath "${1:-build/release}")
packages=(hapticd libhapticopt-dev libhapticd-client-dev)
start=$(date +%s)
step() { printf '\n--- debian packages: %s (%ss) ---\n' "$1" "$(($(date +%s) - start))"; }
fail() { echo "test-debian-packages: $*" >&2; exit 1; }
[[ $(id -u) -eq 0 ]] || fail "needs root: it installs and purges the packages"

# Runs "$@" where the checkout (source and build trees) cannot be read: an empty tmpfs with mode 0 over it.
hidden() {
  unshare --mount --propagation private -- sh -c '
    root=$1; shift
    mount -t tmpfs -o mode=0 hapticd-checkout-hidden "$root"
    cd /
    exec env -u HAPTICD_CONFIG "$@"' sh "$root" "$@"
}

step "cpack"
# dpkg's state of a package: "" or not-installed when it is gone, config-files when only removed.
state() { dpkg-query -W -f='${db:Status-Status}' "$1" 2>/dev/null || true; }
for p in "${packages[@]}"; do
  st=$(state "$p")
  [[ -z $st || $st == not-installed ]] || fail "$p is on this machine already ($st): apt-get purge ${packages[*]}"
done
user_existed=0
getent passwd hapticd >/dev/null && user_existed=1
out="$build/debian-packages"
rm -rf "$out"
(cd "$build" && cpack -G DEB -B "$out" >"$build/cpack.log" 2>&1) || { cat "$build/cpack.log"; fail "cpack failed"; }
debs=("$out"/*.deb)
[[ ${#debs[@]} -eq ${#packages[@]} ]] || fail "expected ${#packages[@]} packages in $out, found: ${debs[*]}"
for d in "${debs[@]}"; do
  dpkg-deb --field "$d" Package Version Architecture Depends | sed 's/^/  /'
done

step "lintian"
lintian --fail-on error,warning --info "${debs[@]}"

step "install"
DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends -o Dpkg::Use-Pty=0 "${debs[@]}"
getent passwd hapticd >/dev/null || fail "the postinst did not create the user hapticd"
getent group hapticd >/dev/null || fail "the postinst did not create the group hapticd"

step "the installed hapticd, checkout hidden"
hidden test ! -e "$root/config/hapticd.toml" || fail "the checkout is still readable in the hidden namespace"
help=$(hidden /usr/bin/hapticd --help)
for dir in /etc/hapticd /usr/share/hapticd; do
  grep -q "$dir/hapticd.toml" <<<"$help" || fail "hapticd --help does not name $dir/hapticd.toml"
done
hidden /usr/bin/hapticd --dry-run
hidden /usr/bin/hapticd --criterion CE2 --duration 1
# The search order, each level over the one below it (the rate is printed in the tuning report).
rate_of() { hidden "$@" | grep -o 'rate[ =:]*[0-9.]* Hz' | head -1; }
mkdir /etc/hapticd
printf 'rate = 500.0\n' >/etc/hapticd/hapticd.toml
printf 'rate = 250.0\n' >/tmp/hapticd-env.toml
printf 'rate = 125.0\n' >/tmp/hapticd-cli.toml
printf 'rate = 400.0\n' >/etc/hapticd/left.toml
etc=$(rate_of /usr/bin/hapticd --dry-run)
left=$(rate_of /usr/bin/hapticd --instance left --dry-run)     # /etc/hapticd/left.toml
right=$(rate_of /usr/bin/hapticd --instance right --dry-run)   # no right.toml: /etc/hapticd/hapticd.toml
env_=$(rate_of env HAPTICD_CONFIG=/tmp/hapticd-env.toml /usr/bin/hapticd --dry-run)
cli=$(rate_of env HAPTICD_CONFIG=/tmp/hapticd-env.toml /usr/bin/hapticd --config /tmp/hapticd-cli.toml --dry-run)
rm -rf /etc/hapticd /tmp/hapticd-env.toml /tmp/hapticd-cli.toml
echo "  /etc/hapticd: $etc; \$HAPTICD_CONFIG: $env_; --config: $cli; --instance left: $left; --instance right: $right"
[[ $etc == *500* && $env_ == *250* && $cli == *125* ]] || fail "config search order not --config > \$HAPTICD_CONFIG > /etc/hapticd"
[[ $left == *400* && $right == *500* ]] || fail "--instance NAME does not read /etc/hapticd/NAME.toml before hapticd.toml"
hidden systemd-analyze verify /usr/lib/systemd/system/hapticd.service
# An instance of the template: systemd-analyze finds hapticd@.service for it in /usr/lib/systemd/system.
hidden systemd-analyze verify hapticd@left.service

step "outside projects on the installed CMake packages"
version=$(dpkg-deb --field "$out"/libhapticopt-dev_*.deb Version)
cmake -DSOURCE_DIR="$root/tests/packaging/consumer" -DBINARY_DIR="$build/debian-consumer" -DPREFIX=/usr \
      -DGENERATOR=Ninja -DEXPECTED_VERSION="$version" -P tests/packaging/consumer_check.cmake
cmake -DSOURCE_DIR="$root/tests/packaging/client_consumer" -DCONSUMER_BINARY_DIR="$build/debian-client-consumer" \
      -DPREFIX=/usr -DGENERATOR=Ninja -P tests/packaging/client_package_check.cmake

step "purge"
files=$(for d in "${debs[@]}"; do dpkg-deb --fsys-tarfile "$d" | tar -t | grep -v '/$' | sed 's#^\./#/#'; done)
DEBIAN_FRONTEND=noninteractive apt-get purge -y -qq -o Dpkg::Use-Pty=0 "${packages[@]}"
left=""
for p in "${packages[@]}"; do
  st=$(state "$p")
  [[ -z $st || $st == not-installed ]] || left+=" package:$p($st)"
done
while read -r f; do [[ -e $f || -L $f ]] && left+=" $f"; done <<<"$files"
for d in /usr/share/hapticd /usr/include/hapticopt /usr/include/hapticd /usr/share/cmake/hapticopt \
         /usr/share/cmake/hapticd /var/lib/hapticd /etc/hapticd; do
  [[ -e $d ]] && left+=" $d"
done
[[ -z $left ]] || fail "left after the purge:$left"
if [[ $user_existed -eq 0 ]]; then
  userdel hapticd
  getent group hapticd >/dev/null && groupdel hapticd
fi
step "passed: $(echo "$files" | wc -l) files installed and removed"
