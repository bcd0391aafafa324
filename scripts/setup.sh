#!/usr/bin/env bash
# Installs the Debian 12 packages Chromosphere needs, only those missing.
# Safe to run any number of times. Needs root (or sudo) when something is missing.
set -euo pipefail

packages=(
  # toolchain
  g++ cmake ninja-build pkg-config git
  # the fuzz preset (tests/fuzz/): clang with libFuzzer and the sanitizers' runtime
  clang libclang-rt-14-dev
  # numerics and utilities
  libeigen3-dev libceres-dev libcli11-dev nlohmann-json3-dev libfmt-dev
  # tests and benchmarks
  libgtest-dev libgmock-dev libbenchmark-dev gnuplot-nox
  # images
  libopencv-core-dev libopencv-imgproc-dev libopencv-imgcodecs-dev libopencv-video-dev
  libopenexr-dev libtiff-dev libdeflate-dev
  # devices
  libusb-1.0-0-dev libhidapi-dev libmodbus-dev libaravis-dev aravis-tools
  # tools no one here wrote, pointed at the simulators in the suite: Aravis' arv-tool-0.8, a Modbus master
  aravis-tools-cli mbpoll libxml2-utils
  # the Debian package (packaging/): man pages from --help
  help2man
  # socket API and the Python client; the web view's HTTP(S) server
  protobuf-compiler libprotobuf-dev libgrpc++-dev protobuf-compiler-grpc
  python3 python3-grpcio python3-protobuf
  # the maps in Python: the client package's numpy arrays, the OME-TIFF reader
  # its tests check the files with, the worked example's plots, its venv test
  python3-numpy python3-tifffile python3-matplotlib python3-venv python3-pip python3-setuptools
  libcpp-httplib-dev
  # studies as Slurm job arrays (docs/study.md): the test starts a single-node cluster
  slurmctld slurmd slurm-client munge
  # the web view's browser test (tests/web/): Debian's Chromium, driven by npm's playwright-core
  chromium
)
# The web view's front end builds with Node.js and npm (web/); a machine that
# has them already (any version >= 18) keeps its own.
if ! command -v node >/dev/null || ! command -v npm >/dev/null; then
  packages+=(nodejs npm)
fi

missing=()
for package in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$package")
  fi
done

if ((${#missing[@]} == 0)); then
  echo "setup: all ${#packages[@]} packages present"
  exit 0
fi

echo "setup: installing ${#missing[@]} missing package(s): ${missing[*]}"
sudo_cmd=()
if [[ $(id -u) -ne 0 ]]; then
  command -v sudo >/dev/null || { echo "setup: not root and no sudo; install as root: ${missing[*]}" >&2; exit 1; }
  sudo_cmd=(sudo)
fi
export DEBIAN_FRONTEND=noninteractive
"${sudo_cmd[@]}" apt-get update -qq
"${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
echo "setup: done"
