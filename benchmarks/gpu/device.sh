#!/usr/bin/env bash
# The GPU machine's half of the GPU run (benchmarks/gpu/README.md says the whole procedure). Run from the
# repository root on that machine, one step per call while the machine stays warm:
#
#   device.sh receive NN     append .gpu/part-NN/payload.part (carried with that call) to the payload
#   device.sh install        check the payload's SHA-256, unpack the GL loaders and install the wheels
#   device.sh run ARGS...    `iblcheck paper ARGS...` with NVIDIA's EGL, then the rows and the report to $OUT
#   device.sh script PY ARGS...  `python PY ARGS...` in the same environment (e.g. benchmarks/gpu/e10_frames.py)
#   device.sh script -m MODULE ARGS...  `python -m MODULE ARGS...` there (e.g. -m pytest -m "gl and not mitsuba" tests)
#
# Nothing here downloads anything: the machine reaches no registry. Where it keeps things between calls:
# $IBLCHECK_GPU_HOME (default /opt/iblcheck). Tested on a CPU machine too, with Python 3.12 and Mesa's EGL
# (PYTHON=... IBLCHECK_GPU_HOME=... OUT=... device.sh ...), which is how the project's tests run it.
set -euo pipefail
HOME_DIR=${IBLCHECK_GPU_HOME:-/opt/iblcheck}
PYTHON=${PYTHON:-python3}
MANIFEST=.gpu/manifest.json
step=${1:-}
shift || true

die() { echo "device.sh: $*" >&2; exit 2; }

# the installed wheels and this checkout on the path, NVIDIA's EGL vendor library where the driver has one
installed_env() {
  export PYTHONPATH="$HOME_DIR/site:$PWD${PYTHONPATH:+:$PYTHONPATH}"
  export IBLCHECK_CACHE=${IBLCHECK_CACHE:-$HOME_DIR/cache}
  local nvidia=/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json
  if [ -f "$nvidia" ] && [ -z "${__EGL_VENDOR_LIBRARY_FILENAMES:-}" ]; then
    export __EGL_VENDOR_LIBRARY_FILENAMES=$nvidia
  fi
  "$PYTHON" -c "from realtime.engine.context import renderer_name; print('OpenGL renderer:', renderer_name())"
}

case "$step" in
  receive)
    n=${1:?usage: device.sh receive NN}
    part=.gpu/part-$n/payload.part
    [ -f "$part" ] || die "$part was not carried with this call (carry .gpu/part-$n and $MANIFEST)"
    mkdir -p "$HOME_DIR"
    if [ "$n" = 00 ]; then : > "$HOME_DIR/payload.tar"; fi
    cat "$part" >> "$HOME_DIR/payload.tar"
    echo "received part $n: $(stat -c %s "$HOME_DIR/payload.tar") bytes so far"
    ;;
  install)
    [ -f "$MANIFEST" ] || die "$MANIFEST was not carried with this call"
    want=$("$PYTHON" -c "import json; print(json.load(open('$MANIFEST'))['sha256'])")
    have=$(sha256sum "$HOME_DIR/payload.tar" | cut -d' ' -f1)
    [ "$want" = "$have" ] || die "payload checksum $have, manifest says $want: receive every part in order"
    rm -rf "$HOME_DIR/payload" "$HOME_DIR/site"
    mkdir -p "$HOME_DIR/payload" "$HOME_DIR/site" "$HOME_DIR/cache"
    tar -xf "$HOME_DIR/payload.tar" -C "$HOME_DIR/payload"
    if [ -d "$HOME_DIR/payload/gl" ] && [ "${IBLCHECK_GPU_SKIP_GL:-0}" != 1 ]; then
      for f in "$HOME_DIR"/payload/gl/*.deb; do dpkg -x "$f" /; done
      ldconfig
    fi
    "$PYTHON" -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --target "$HOME_DIR/site" \
      "$HOME_DIR"/payload/wheels/*.whl
    if [ -d "$HOME_DIR/payload/cache" ]; then cp -r "$HOME_DIR/payload/cache/." "$HOME_DIR/cache/"; fi
    echo "installed $(ls "$HOME_DIR"/payload/wheels | wc -l) wheels into $HOME_DIR/site"
    ;;
  run)
    : "${OUT:?OUT (the folder whose files come back) is not set}"
    installed_env
    out="$HOME_DIR/out"
    "$PYTHON" -m experiments.cli paper --out "$out" "$@"
    for f in results.jsonl summary.md experiments.json; do
      [ -f "$out/$f" ] && cp "$out/$f" "$OUT/$f"
    done
    if [ -d "$out/figures" ]; then tar -czf "$OUT/figures.tar.gz" -C "$out" figures; fi
    ;;
  script)
    py=${1:-}
    [ -n "$py" ] || die "usage: device.sh script PY ARGS... | script -m MODULE ARGS..."
    shift
    if [ "$py" = -m ]; then
      module=${1:-}
      [ -n "$module" ] || die "usage: device.sh script -m MODULE ARGS... (e.g. -m pytest -m gl tests)"
      shift
      installed_env
      "$PYTHON" -m "$module" "$@"
    else
      [ -f "$py" ] || die "$py: no such script in this checkout"
      installed_env
      "$PYTHON" "$py" "$@"
    fi
    ;;
  *)
    die "usage: device.sh receive NN | install | run PAPER-ARGS... | script PY ARGS... | script -m MODULE ARGS..."
    ;;
esac
