#!/usr/bin/env bash
# Installs Mesa's lavapipe (software Vulkan) when no Vulkan driver is present, and xvfb when a
# window test needs a display. Idempotent: does nothing on a machine that already has both.
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
if [ "$want_xvfb" = 1 ] && ! command -v Xvfb >/dev/null; then packages+=(xvfb); fi
[ ${#packages[@]} -eq 0 ] && exit 0

echo "wgbragg: installing ${packages[*]} (no Vulkan driver or display found)" >&2
sudo=""
[ "$(id -u)" = 0 ] || sudo="sudo"
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
$sudo apt-get install -y -qq --no-install-recommends "${packages[@]}" >/dev/null
