#!/usr/bin/env bash
# Installs the Debian packages iblcheck needs when they are missing and apt-get is usable.
# Idempotent and quick when everything is present.
set -euo pipefail
need=()
ls /usr/lib/*/libLLVM-19.so* >/dev/null 2>&1 || ls /usr/lib/*/libLLVM.so.19* >/dev/null 2>&1 || need+=(libllvm19)
ls /usr/lib/*/libEGL.so.1 >/dev/null 2>&1 || need+=(libegl1 libgl1-mesa-dri)
# `--test`: headless Chromium for the report test (it opens the HTML report and reads the console)
if [ "${1:-}" = "--test" ]; then command -v chromium >/dev/null || need+=(chromium); fi
[ ${#need[@]} -eq 0 ] && exit 0
if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null; then
  echo "installing Debian packages: ${need[*]}"
  apt-get update -qq
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${need[@]}" >/dev/null
else
  echo "warning: missing Debian packages ${need[*]} (not root or no apt-get); Mitsuba falls back to scalar_rgb" >&2
fi
