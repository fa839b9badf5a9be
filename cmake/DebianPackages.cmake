# SPDX-License-Identifier: Apache-2.0
# Debian packages with CPack's DEB generator, one per install component (docs/building.md, "Debian packages"):
#   hapticd                 component runtime: hapticd, hapticctl, hapticopt, /usr/share/hapticd (config and
#                           device profiles), the systemd unit, the sysusers.d file, the udev rules
#   libhapticopt-dev        component hapticopt_dev: the header-only library, its compiled mode (a static library,
#                           so the package is architecture-specific) and its CMake package
#   libhapticd-client-dev   component hapticd_client_dev: the client library (static), its headers and CMake package
# Build them from a configured and built tree:  cd <build> && cpack -G DEB   (scripts/test-debian-packages.sh).
# Run-time dependencies come from dpkg-shlibdeps; the maintainer scripts are packaging/debian/hapticd/.
# The binaries find their data relative to themselves (src/config/config_locations.hpp) and the unit's ExecStart
# is configured at install time, so the packages come from any build tree, whatever its CMAKE_INSTALL_PREFIX:
# CPack installs with DESTDIR and the prefix /usr.

set(_deb_dir "${PROJECT_SOURCE_DIR}/packaging/debian")

# /usr/share/doc/<package>/{copyright,changelog.gz}, only in the packages (EXCLUDE_FROM_ALL: a plain
# `cmake --install` does not install them). The changelog is compressed as Debian policy asks (gzip -9n).
execute_process(COMMAND gzip -9nc "${_deb_dir}/changelog"
                OUTPUT_FILE "${PROJECT_BINARY_DIR}/debian-changelog.gz" COMMAND_ERROR_IS_FATAL ANY)
set(_deb_packages runtime hapticd hapticopt_dev libhapticopt-dev hapticd_client_dev libhapticd-client-dev)
while(_deb_packages)
  list(POP_FRONT _deb_packages _component _package)
  install(FILES "${_deb_dir}/copyright" DESTINATION "${CMAKE_INSTALL_DATAROOTDIR}/doc/${_package}"
          COMPONENT ${_component} EXCLUDE_FROM_ALL)
  install(FILES "${PROJECT_BINARY_DIR}/debian-changelog.gz" DESTINATION "${CMAKE_INSTALL_DATAROOTDIR}/doc/${_package}"
          RENAME changelog.gz COMPONENT ${_component} EXCLUDE_FROM_ALL)
  if(EXISTS "${_deb_dir}/${_package}.lintian-overrides")
    install(FILES "${_deb_dir}/${_package}.lintian-overrides" DESTINATION "${CMAKE_INSTALL_DATAROOTDIR}/lintian/overrides"
            RENAME ${_package} COMPONENT ${_component} EXCLUDE_FROM_ALL)
  endif()
endwhile()

set(CPACK_GENERATOR DEB)
set(CPACK_PACKAGE_NAME hapticd)
set(CPACK_PACKAGE_VENDOR "The hapticd authors")
set(CPACK_PACKAGE_CONTACT "hapticd maintainers <hapticd@example.org>")
set(CPACK_PACKAGE_VERSION "${PROJECT_VERSION}")
# Each component's description below starts with its own synopsis line; CPackDeb prepends
# CPACK_PACKAGE_DESCRIPTION_SUMMARY to it unless that is CPack's default text, which it is set to here.
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "${CMAKE_PROJECT_NAME} built using CMake")
set(CPACK_RESOURCE_FILE_LICENSE "${PROJECT_SOURCE_DIR}/LICENSE")
set(CPACK_PACKAGING_INSTALL_PREFIX /usr)
set(CPACK_SET_DESTDIR ON)
set(CPACK_INSTALL_PREFIX /usr)  # with DESTDIR: the prefix the install scripts (and the unit's ExecStart) see
set(CPACK_STRIP_FILES ON)
set(CPACK_COMPONENTS_ALL runtime hapticopt_dev)
if(TARGET hapticd_client)
  list(APPEND CPACK_COMPONENTS_ALL hapticd_client_dev)
endif()
set(CPACK_DEB_COMPONENT_INSTALL ON)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
set(CPACK_DEBIAN_PACKAGE_PRIORITY optional)
set(CPACK_DEBIAN_PACKAGE_CONTROL_STRICT_PERMISSION ON)

set(CPACK_DEBIAN_RUNTIME_PACKAGE_NAME hapticd)
set(CPACK_DEBIAN_RUNTIME_PACKAGE_SECTION science)
# systemd-sysusers (postinst) is in systemd, or alone in systemd-standalone-sysusers; deb-systemd-invoke and
# deb-systemd-helper are in init-system-helpers.
set(CPACK_DEBIAN_RUNTIME_PACKAGE_DEPENDS "systemd | systemd-standalone-sysusers, init-system-helpers (>= 1.54~)")
set(CPACK_DEBIAN_RUNTIME_PACKAGE_CONTROL_EXTRA
    "${_deb_dir}/hapticd/postinst;${_deb_dir}/hapticd/prerm;${_deb_dir}/hapticd/postrm")
set(CPACK_COMPONENT_RUNTIME_DESCRIPTION "real-time haptic wall server with optimally tuned gains
hapticd renders virtual walls on a haptic device (Novint Falcon over libusb,
HID force-feedback devices over hidapi, or a simulated device) at a fixed
rate, with stiffness and damping chosen as the optimum of the criteria of
Hulin, Gonzalez Camarero and Albu-Schaeffer (IROS 2011) and checked stable
for the loop that runs. It serves client applications over a Unix socket.

This package holds hapticd, the client hapticctl, the analysis program
hapticopt, the default configuration and device profiles, the systemd
service (disabled until enabled), its system user and the udev rules.")

set(CPACK_DEBIAN_HAPTICOPT_DEV_PACKAGE_NAME libhapticopt-dev)
set(CPACK_DEBIAN_HAPTICOPT_DEV_PACKAGE_SECTION libdevel)
set(CPACK_DEBIAN_HAPTICOPT_DEV_PACKAGE_DEPENDS "libeigen3-dev (>= 3.4)")
set(CPACK_COMPONENT_HAPTICOPT_DEV_DESCRIPTION "optimal virtual-wall tuning for haptic rendering (C++17 headers)
hapticopt is a header-only C++17 library on Eigen that computes the
stability region and the optimal stiffness and damping of a sampled virtual
wall with delay for the criteria of Hulin, Gonzalez Camarero and
Albu-Schaeffer (IROS 2011).

This package holds the headers, the compiled-mode static library and the
CMake package: find_package(hapticopt) gives the targets hapticopt::hapticopt
(header-only) and hapticopt::compiled (the same API, built once).")

set(CPACK_DEBIAN_HAPTICD_CLIENT_DEV_PACKAGE_NAME libhapticd-client-dev)
set(CPACK_DEBIAN_HAPTICD_CLIENT_DEV_PACKAGE_SECTION libdevel)
set(CPACK_COMPONENT_HAPTICD_CLIENT_DEV_DESCRIPTION "client library for the hapticd haptic wall server (static)
The C++ client of the hapticd protocol: connect to the daemon's socket, add
and move walls and objects, and read the device state from its shared
memory at the loop rate.

This package holds the static library, its headers and the CMake package:
find_package(hapticd) gives the target hapticd::client.")

include(CPack)
