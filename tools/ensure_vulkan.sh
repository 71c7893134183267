#!/usr/bin/env bash
# Installs Mesa's lavapipe (software Vulkan) when no Vulkan driver is present, and, with
# WGBRAGG_NEED_XVFB=1, Xvfb and the X client libraries glfw loads when Xvfb is missing (the demo
# window's tests). Idempotent: does nothing on a machine that already has them.
set -euo pipefail

want_xvfb=${WGBRAGG_NEED_XVFB:-0}
packages=()
icd_dirs=(/usr/share/vulkan/icd.d /etc/vulkan/icd.d /usr/local/share/vulkan/icd.d)
have_icd=0
for dir in "${icd_dirs[@]}"; do
    if compgen -G "$dir/*.json" >/dev/null; then have_icd=1; fi
done
[ -n "${VK_DRIVER_FILES:-}${VK_ICD_FILENAMES:-}" ] && have_icd=1
[ "$have_icd" = 1 ] || packages+=(mesa-vulkan-drivers)
if [ "$want_xvfb" = 1 ]; then
    command -v Xvfb >/dev/null || packages+=(xvfb)
    # glfw loads these with dlopen, so nothing else would pull them in.
    for pair in libx11-6:libX11.so.6 libx11-xcb1:libX11-xcb.so.1 libxrandr2:libXrandr.so.2 \
                libxinerama1:libXinerama.so.1 libxcursor1:libXcursor.so.1 libxi6:libXi.so.6; do
        ldconfig -p | grep -q "${pair#*:}" || packages+=("${pair%%:*}")
    done
fi
[ ${#packages[@]} -eq 0 ] && exit 0

echo "wgbragg: installing ${packages[*]} (no Vulkan driver, or no Xvfb)" >&2
sudo=""
[ "$(id -u)" = 0 ] || sudo="sudo"
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${packages[@]}" >/dev/null
