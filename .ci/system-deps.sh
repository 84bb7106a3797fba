#!/usr/bin/env bash
# Installs the Debian packages iblcheck needs when they are missing and apt-get is usable.
# Idempotent and quick when everything is present.
#   (no argument)  libllvm19 (Mitsuba's llvm variant; Debian 12's LLVM 15 aborts) and EGL/Mesa
#   --test         also headless Chromium for the report test; best effort: if it cannot be
#                  installed, that one test skips and says why
# Node.js, npm and Chromium for the web engines (engines/web: three.js, Babylon.js) are installed in both
# modes, best effort with a warning: without them those engines and their tests are unavailable.
set -euo pipefail
need=()
ls /usr/lib/*/libLLVM-19.so* >/dev/null 2>&1 || ls /usr/lib/*/libLLVM.so.19* >/dev/null 2>&1 || need+=(libllvm19)
ls /usr/lib/*/libEGL.so.1 >/dev/null 2>&1 || need+=(libegl1 libgl1-mesa-dri)
want_chromium=0
if ! command -v chromium >/dev/null; then want_chromium=1; fi
web=()
command -v node >/dev/null || web+=(nodejs)
command -v npm >/dev/null || web+=(npm)
[ ${#need[@]} -eq 0 ] && [ $want_chromium -eq 0 ] && [ ${#web[@]} -eq 0 ] && exit 0
if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
  apt-get update -qq
  if [ ${#need[@]} -gt 0 ]; then
    echo "installing Debian packages: ${need[*]}"
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${need[@]}" >/dev/null
  fi
  if [ $want_chromium -eq 1 ]; then
    echo "installing Debian's chromium (the report test and the web engines)"
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null \
      || echo "warning: chromium could not be installed; the browser tests will skip" >&2
  fi
  if [ ${#web[@]} -gt 0 ]; then
    echo "installing Debian packages for the web engines: ${web[*]}"
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${web[@]}" >/dev/null \
      || echo "warning: ${web[*]} could not be installed; the three.js/Babylon.js engines will be unavailable" >&2
  fi
else
  [ $want_chromium -eq 1 ] && need+=(chromium)
  need+=("${web[@]}")
  echo "warning: missing Debian packages ${need[*]} (not root or no apt-get)" >&2
fi
