#!/usr/bin/env bash
# The main job: path-traced stereo renders of the real head MRI (Debian's mricron-data) under
# a real HDR panorama (blender-data), written to holovolume-output/. Installs and builds on
# first use; every argument goes to the holovolume application (try --help).
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
holovolume_install_dependencies
if [ -f "$HOLOVOLUME_BUILD_DIR/build.ninja" ]; then
  # Already configured: bring the build up to date (a no-op when nothing changed).
  cmake --build "$HOLOVOLUME_BUILD_DIR" --parallel "$(nproc)" >"$HOLOVOLUME_BUILD_DIR/build.log" 2>&1 ||
    { cat "$HOLOVOLUME_BUILD_DIR/build.log"; exit 1; }
else
  holovolume_build
fi
exec "$HOLOVOLUME_BUILD_DIR/bin/holovolume" "$@"
