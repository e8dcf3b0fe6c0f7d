# Shared by the scripts: paths, the package list, install and build steps.
# shellcheck shell=bash
# Two layouts. The source tree: PTZ_ROOT is the checkout, programs in the build dir PTZ_BUILD.
# An install (cmake --install, the .deb): these scripts in PREFIX/share/ptzstereo/scripts beside
# install-paths.sh (written by the install), PTZ_ROOT is PREFIX/share/ptzstereo (config/,
# scripts/), programs in PREFIX/bin; every path from this folder, so a moved prefix still works.
PTZ_ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
PTZ_INSTALLED=0
if [ -f "$PTZ_ROOT/scripts/install-paths.sh" ]; then
  PTZ_INSTALLED=1
  source "$PTZ_ROOT/scripts/install-paths.sh"  # PTZ_INSTALL_BIN, PTZ_INSTALL_JAVA: from scripts/
  PTZ_BIN_DIR=$(cd "$PTZ_ROOT/scripts" && cd "$PTZ_INSTALL_BIN" && pwd)
  PTZ_TYPES_JAR=$(cd "$PTZ_ROOT/scripts" && cd "$PTZ_INSTALL_JAVA" && pwd)/ptzstereo_lcmtypes.jar
  PTZ_OUT=${PTZ_OUT:-$PWD/out}  # runs' output: the install is no place for it
else
  PTZ_BUILD=${PTZ_BUILD:-$PTZ_ROOT/build}
  PTZ_TYPES_JAR=$PTZ_BUILD/ptzstereo_lcmtypes.jar
  PTZ_OUT=${PTZ_OUT:-$PTZ_ROOT/out}
fi

# ptz-depth's niceness in scripts/demo and scripts/run-host, as deploy/systemd's Nice=10: tracking
# first, yet enough CPU beside two busy cores (at 19 a restarted ptz-depth sent nothing for 20 s).
PTZ_DEPTH_NICE=10

# ptz_bin NAME: the path of program NAME (ptz-sim, ptz-detect, ...) in this layout. A program not
# there is named with what to do; the path is printed all the same (its run then fails by name).
ptz_bin() {
  local name=$1 d
  if [ "$PTZ_INSTALLED" = 1 ]; then
    [ -x "$PTZ_BIN_DIR/$name" ] || echo "ptz_bin: $PTZ_BIN_DIR/$name is missing (reinstall)" >&2
    echo "$PTZ_BIN_DIR/$name"
    return 0
  fi
  for d in sim perception control tools ptz_driver; do
    [ -x "$PTZ_BUILD/$d/$name" ] && { echo "$PTZ_BUILD/$d/$name"; return 0; }
  done
  echo "ptz_bin: $name is not built in $PTZ_BUILD (build it, or set PTZ_BUILD)" >&2
  echo "$PTZ_BUILD/$name"
}

# Debian 12 / Ubuntu packages: what builds and runs the programs (scripts/demo installs only
# these, ccache included), then what the tests, fuzz targets and tools for them add.
PTZ_DEMO_PACKAGES=(
  build-essential cmake pkg-config ccache ninja-build
  liblcm-dev liblcm-bin libglib2.0-dev
  libopencv-dev libopencv-contrib-dev libeigen3-dev libpcl-dev
  # fiducial markers: AprilTag (ArUco is in OpenCV contrib); faces: OpenCV's cascades
  libapriltag-dev opencv-data
  libgpiod-dev libsystemd-dev libjpeg-dev
  # ONVIF cameras: SOAP parsed by libxml2, WS-Security digests by OpenSSL, HTTP by libcurl
  libxml2-dev libssl-dev libcurl4-openssl-dev
  # Foxglove: MCAP export (JSON messages, zstd chunks) and the WebSocket bridge
  nlohmann-json3-dev libzstd-dev zlib1g-dev libwebsocketpp-dev libasio-dev
  # ptz-report's plots; the demo's private network
  gnuplot-nox iproute2
)
PTZ_PACKAGES=(
  "${PTZ_DEMO_PACKAGES[@]}" clang-format pcl-tools
  libgtest-dev
  # lcm-spy and the types' jar
  liblcm-java default-jdk-headless libjchart2d-java
  # a step of the wall clock under a real process (test/system/test_sim_processes.cpp)
  libfaketime
  # the fuzz targets (fuzz/, scripts/fuzz): Debian 12's clang 14, libFuzzer and sanitizer runtimes
  clang-14 libfuzzer-14-dev libclang-rt-14-dev
  # GStreamer for ptz-camera's RTSP cameras (plugins-bad: openh264dec, their H.264 decoder)
  gstreamer1.0-plugins-base gstreamer1.0-plugins-good gstreamer1.0-plugins-bad gstreamer1.0-rtsp
  libgstrtspserver-1.0-dev
  gstreamer1.0-tools
  nftables xvfb x11-apps imagemagick xdotool
  # cpack -G DEB (test/deploy): its shared-library dependencies are read with file
  file
  # real photographs for the face and people detectors' tests (OpenCV's samples)
  opencv-doc
)

ptz_sudo() {
  if [ "$(id -u)" -eq 0 ]; then "$@"; else sudo "$@"; fi
}

# ptz_install_deps [demo]: installs what is missing of PTZ_PACKAGES (of PTZ_DEMO_PACKAGES).
ptz_install_deps() {
  [ "$PTZ_INSTALLED" = 0 ] || return 0  # an install's package declares what it needs
  if [ "${1:-}" = demo ]; then
    ptz_install_packages "${PTZ_DEMO_PACKAGES[@]}"
  else
    ptz_install_packages "${PTZ_PACKAGES[@]}"
  fi
}

# ptz_install_packages PACKAGE...: apt-get installs those not installed yet.
ptz_install_packages() {
  local missing=()
  for p in "$@"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  if [ ${#missing[@]} -eq 0 ]; then
    return 0
  fi
  echo "Installing: ${missing[*]}"
  ptz_sudo apt-get update -q
  ptz_sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends \
    "${missing[@]}"
}

# Node.js and npm for the test-only JavaScript checkers (test/js: @mcap/core, @foxglove/schemas,
# @foxglove/ws-protocol). A machine that has a node of its own (e.g. NodeSource's, which bundles
# npm) keeps it: Debian's npm package would conflict with it.
ptz_install_node() {
  if command -v node >/dev/null && command -v npm >/dev/null; then
    return 0
  fi
  echo "Installing: nodejs npm"
  ptz_sudo apt-get update -q
  ptz_sudo env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends nodejs npm
}

# ptz_generator: the CMake generator flag for a new build dir (Ninja where installed: it keeps both
# cores busy across targets, where make builds one target's files at a time); nothing for a build
# dir that exists, which keeps its own.
ptz_generator() {
  if [ ! -f "$PTZ_BUILD/CMakeCache.txt" ] && command -v ninja >/dev/null; then
    echo "-GNinja"
  fi
}

# ptz_build [CMAKE_ARGS...]: configures and builds everything.
ptz_build() {
  [ "$PTZ_INSTALLED" = 0 ] || return 0  # nothing to build: the programs are installed
  # shellcheck disable=SC2046  # the generator is one word or none
  cmake -S "$PTZ_ROOT" -B "$PTZ_BUILD" $(ptz_generator) -DCMAKE_BUILD_TYPE=RelWithDebInfo "$@" \
    >/dev/null
  cmake --build "$PTZ_BUILD" -j"$(ptz_jobs)"
}

# ptz_build_programs NAME...: configures (as ptz_build) and builds only these programs and what
# they link: a first demo does not wait for the tests and fuzz targets.
# A new build dir is configured without the tests (their packages may be missing); one that has
# them keeps them.
ptz_build_programs() {
  [ "$PTZ_INSTALLED" = 0 ] || return 0
  local testing=() generator
  generator=$(ptz_generator)
  [ -f "$PTZ_BUILD/CMakeCache.txt" ] || testing=(-DBUILD_TESTING=OFF)
  # Explicit returns: callers run this inside `if`, where set -e does not act.
  # shellcheck disable=SC2086  # the generator is one word or none
  cmake -S "$PTZ_ROOT" -B "$PTZ_BUILD" $generator -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    "${testing[@]}" >/dev/null || return 1
  cmake --build "$PTZ_BUILD" -j"$(ptz_jobs)" --target "$@" || return 1
}

# ptz_install_and_build_demo: the demo's packages and programs. On a machine without PCL its
# ~430 packages install while everything but ptz-depth builds (a first demo a minute sooner).
ptz_install_and_build_demo() {
  [ "$PTZ_INSTALLED" = 0 ] || return 0
  local pcl=libpcl-dev pcl_log pcl_pid others=()
  if dpkg-query -W -f='${Status}' "$pcl" 2>/dev/null | grep -q "install ok installed"; then
    ptz_install_packages "${PTZ_DEMO_PACKAGES[@]}"
  else
    for p in "${PTZ_DEMO_PACKAGES[@]}"; do [ "$p" = "$pcl" ] || others+=("$p"); done
    ptz_install_packages "${others[@]}"
    pcl_log=$(mktemp)
    echo "Installing $pcl (log: $pcl_log) while the other programs build ..."
    ptz_install_packages "$pcl" >"$pcl_log" 2>&1 &
    pcl_pid=$!
    # Without PCL the target leaves ptz-depth out (the top CMakeLists.txt).
    if ! ptz_build_programs ptz_demo_programs; then
      wait "$pcl_pid" || true
      return 1
    fi
    if ! wait "$pcl_pid"; then
      cat "$pcl_log" >&2
      echo "Installing $pcl failed (above)" >&2
      return 1
    fi
    rm -f "$pcl_log"
  fi
  echo "Building the demo's programs in $PTZ_BUILD ..."
  ptz_build_programs ptz_demo_programs
}

# Build jobs: one a core (PTZ_JOBS overrides).
ptz_jobs() {
  echo "${PTZ_JOBS:-$(nproc 2>/dev/null || echo 2)}"
}

# Prints what is wrong with the host's LCM networking and the exact fix; returns non-zero then.
ptz_check_network() {
  local ok=0
  local rmem
  rmem=$(cat /proc/sys/net/core/rmem_max 2>/dev/null || echo 0)
  if [ "$rmem" -lt 4194304 ]; then
    echo "net.core.rmem_max is $rmem: raw VGA stereo frames (~1.8 MB) will be lost."
    echo "  fix: sudo sysctl -w net.core.rmem_max=4194304"
    echo "  (permanent: echo net.core.rmem_max=4194304 | sudo tee /etc/sysctl.d/60-lcm.conf)"
    ok=1
  fi
  if ! ip route get 239.255.76.67 >/dev/null 2>&1; then
    echo "No route for LCM's multicast group 239.255.76.67: processes cannot talk."
    echo "  fix: sudo ip route add 224.0.0.0/4 dev lo && sudo ip link set lo multicast on"
    ok=1
  fi
  return $ok
}
