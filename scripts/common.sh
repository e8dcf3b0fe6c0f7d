# Shared by the scripts: paths, the package list, install and build steps.
# shellcheck shell=bash
PTZ_ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
PTZ_BUILD=${PTZ_BUILD:-$PTZ_ROOT/build}

# Debian 12 / Ubuntu packages the project builds, tests and runs with.
PTZ_PACKAGES=(
  build-essential cmake pkg-config clang-format
  liblcm-dev liblcm-bin liblcm-java libglib2.0-dev
  libopencv-dev libopencv-contrib-dev libeigen3-dev libpcl-dev pcl-tools
  libgpiod-dev libgtest-dev libsystemd-dev libjpeg-dev
  # the fuzz targets (fuzz/, scripts/fuzz): Debian 12's clang 14, libFuzzer and sanitizer runtimes
  clang-14 libfuzzer-14-dev libclang-rt-14-dev
  # GStreamer for ptz-camera's RTSP cameras (plugins-bad: openh264dec, their H.264 decoder)
  gstreamer1.0-plugins-base gstreamer1.0-plugins-good gstreamer1.0-plugins-bad gstreamer1.0-rtsp
  libgstrtspserver-1.0-dev
  gstreamer1.0-tools
  default-jdk-headless libjchart2d-java
  iproute2 nftables xvfb x11-apps imagemagick xdotool gnuplot-nox
)

ptz_sudo() {
  if [ "$(id -u)" -eq 0 ]; then "$@"; else sudo "$@"; fi
}

ptz_install_deps() {
  local missing=()
  for p in "${PTZ_PACKAGES[@]}"; do
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

ptz_build() {
  cmake -S "$PTZ_ROOT" -B "$PTZ_BUILD" -DCMAKE_BUILD_TYPE=RelWithDebInfo "$@" >/dev/null
  cmake --build "$PTZ_BUILD" -j2
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
