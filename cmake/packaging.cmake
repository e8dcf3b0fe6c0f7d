# `cpack -G DEB` in the build dir: the package ptzstereo, everything `cmake --install` installs
# (at CMAKE_INSTALL_PREFIX: the systemd units name their programs there; configure with
# -DCMAKE_INSTALL_PREFIX=/usr for a package of /usr). Depends: the shared libraries the programs
# link (dpkg-shlibdeps, package dpkg-dev) and what the scripts run.
set(PTZ_DEB_MAINTAINER "Seed 7a48f1bc maintainers <maintainers@users.noreply.h-seed-7a48f1bc.example>"
  CACHE STRING "Maintainer field of the Debian package")
set(CPACK_PACKAGE_NAME ptzstereo)
set(CPACK_PACKAGE_VERSION ${PROJECT_VERSION})
set(CPACK_PACKAGE_DESCRIPTION_SUMMARY "active stereo vision with two pan-tilt-zoom cameras")
set(CPACK_DEBIAN_PACKAGE_DESCRIPTION "active stereo vision with two pan-tilt-zoom cameras
 Calibrates two PTZ cameras, finds objects in both images, reconstructs them in 3D and steers
 pan, tilt and zoom to keep them centred; small processes talking over LCM, a simulator, the
 drivers of VISCA, Pelco-D and GPIO heads, systemd units, and the libraries and CMake and
 pkg-config files to build against the message types and models.")
set(CPACK_DEBIAN_PACKAGE_MAINTAINER "${PTZ_DEB_MAINTAINER}")
set(CPACK_DEBIAN_PACKAGE_SECTION science)
set(CPACK_DEBIAN_FILE_NAME DEB-DEFAULT)
set(CPACK_PACKAGING_INSTALL_PREFIX ${CMAKE_INSTALL_PREFIX})
# DESTDIR staging: the systemd configs go to /etc/ptzstereo, outside the prefix (conffiles).
set(CPACK_SET_DESTDIR ON)
set(CPACK_DEBIAN_PACKAGE_CONTROL_EXTRA ${PTZ_DEB_CONFFILES})
set(CPACK_STRIP_FILES ON)
set(CPACK_DEBIAN_PACKAGE_SHLIBDEPS ON)
# Added to the shared libraries' packages: lcm-logger (demo, run-rig), ip and unshare (demo
# --private-net, check-network, the several-hosts scripts).
set(CPACK_DEBIAN_PACKAGE_DEPENDS "liblcm-bin, iproute2, util-linux")
# lcm-spy (Java); RTSP cameras (GStreamer); demo-hosts' loss (nftables); stability-sweep's plot;
# ptz-detect's face cascades (opencv-data).
set(CPACK_DEBIAN_PACKAGE_RECOMMENDS "opencv-data, default-jre-headless | java-runtime-headless, liblcm-java, \
libjchart2d-java, gstreamer1.0-plugins-good, gstreamer1.0-plugins-bad, gstreamer1.0-rtsp, \
nftables, gnuplot-nox")
# Building against the libraries (find_package(ptzstereo), pkg-config ptzstereo).
set(CPACK_DEBIAN_PACKAGE_SUGGESTS "liblcm-dev, libopencv-dev, libeigen3-dev, libjpeg-dev, \
libsystemd-dev, pkg-config, cmake")
include(CPack)
