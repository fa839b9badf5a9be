#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Install the Debian 12 packages needed to build and test hapticopt/hapticd.
# Idempotent: if everything is already installed it returns immediately
# without touching apt (no `apt-get update`, no network).
set -euo pipefail

PACKAGES=(
  build-essential
  cmake
  ninja-build
  ccache            # the compiler cache scripts/build-and-test.sh uses (outside the checkout)
  pkg-config
  libeigen3-dev
  libcli11-dev
  libgtest-dev
  libgmock-dev
  libbenchmark-dev
  nlohmann-json3-dev
  libassimp-dev     # Open Asset Import: `hapticctl add mesh FILE.stl|FILE.obj` reads meshes (apps/hapticctl/mesh_file.cpp); the
                    # runtime package gets libassimp5 through dpkg-shlibdeps
  libtomlplusplus-dev  # toml++: hapticd's config file and device profiles (src/config/config_file.cpp)
  libusb-1.0-0-dev
  libhidapi-dev
  libsystemd-dev  # sd_notify: hapticd under systemd Type=notify with the watchdog
  umockdev          # emulated USB/hidraw devices for the `usb` tests (umockdev-wrapper)
  libumockdev-dev   # the UMockdevTestbed API used by those tests
  rt-tests          # cyclictest, the latency baseline beside hapticd's loop
  chromium  # headless SVG rendering in tests/plots (the test is SKIPPED without it)
  python3-dev python3-venv python3-pip pybind11-dev  # the Python package (python/, scripts/test-python.sh)
  python3-numpy python3-scipy python3-matplotlib python3-pytest  # its run time, reference and tests
  xvfb xauth        # xvfb-run: a virtual X display for the scope's window-mode test (python/tests/test_scope.py)
  libembree-dev     # Embree 3: only the mesh benchmark's comparison (tests/benchmarks/mesh.cmake, optional)
  clang-format      # the C++ style check (scripts/check-format.sh, ctest layout.format)
  dpkg-dev lintian  # the Debian packages: dpkg-shlibdeps (CPack), lintian (scripts/test-debian-packages.sh)
  systemd           # systemd-analyze verify, systemd-sysusers (the package's postinst)
  openssh-server openssh-client  # sshd started by python/tests/test_remote.py itself (the ssh service is not used)
)

missing=()
for pkg in "${PACKAGES[@]}"; do
  status=$(dpkg-query -W -f='${db:Status-Status}' "$pkg" 2>/dev/null || true)
  if [[ "$status" != "installed" ]]; then
    missing+=("$pkg")
  fi
done

if [[ ${#missing[@]} -eq 0 ]]; then
  echo "install-deps: all ${#PACKAGES[@]} packages already installed"
  exit 0
fi

SUDO=()
if [[ $(id -u) -ne 0 ]]; then
  if ! command -v sudo >/dev/null 2>&1; then
    echo "install-deps: need root (or sudo) to install: ${missing[*]}" >&2
    exit 1
  fi
  SUDO=(sudo)
fi

echo "install-deps: installing ${missing[*]}"
log=$(mktemp "${TMPDIR:-/tmp}/hapticopt-install-deps.XXXXXX.log")
run() {
  if ! "${SUDO[@]}" env DEBIAN_FRONTEND=noninteractive "$@" >>"$log" 2>&1; then
    echo "install-deps: '$*' failed; log follows:" >&2
    cat "$log" >&2
    rm -f "$log"
    exit 1
  fi
}
run apt-get update -qq
run apt-get install -y -qq --no-install-recommends -o Dpkg::Use-Pty=0 "${missing[@]}"
# openssh-server is there for the sshd the remote-client tests start themselves: the system's ssh service,
# which the package enables and starts, is stopped and disabled again (nothing listens on port 22 for the tests).
if [[ " ${missing[*]} " == *" openssh-server "* ]] && command -v systemctl >/dev/null 2>&1; then
  "${SUDO[@]}" systemctl disable ssh.service >>"$log" 2>&1 || true
  "${SUDO[@]}" systemctl stop ssh.service >>"$log" 2>&1 || true
fi
rm -f "$log"
echo "install-deps: done"
