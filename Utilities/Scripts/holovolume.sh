#!/usr/bin/env bash
# The main job: path-traced stereo renders of the real head MRI (Debian's mricron-data) under
# a real HDR panorama (blender-data), written to holovolume-output/. Installs and builds on
# first use; every argument goes to the holovolume application (try --help).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
holovolume_install_dependencies
if [ ! -x "$HOLOVOLUME_BUILD_DIR/bin/holovolume" ]; then
  mkdir -p "$HOLOVOLUME_BUILD_DIR"
  holovolume_build
fi
exec "$HOLOVOLUME_BUILD_DIR/bin/holovolume" "$@"
