#!/usr/bin/env bash
# Builds HoloVolume (warnings as errors) and runs the whole test suite under Xvfb:
# GoogleTest kernel tests, VTK baseline-image and behaviour tests, Python tests, application
# tests. Installs what is missing on first use. Extra arguments go to ctest.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/setup.sh"
holovolume_install_dependencies
holovolume_install_web_test_tools
mkdir -p "$HOLOVOLUME_BUILD_DIR"
holovolume_build
cd "$HOLOVOLUME_BUILD_DIR"
# -noreset: by default Xvfb resets whenever its last client disconnects, and a test that
# opens its window during that reset gets "bad X server connection" (with two tests in
# parallel, about 2.5% of connections failed in a connect/disconnect loop; none with -noreset).
xvfb-run -a -s "-screen 0 1920x1080x24 -noreset" ctest --output-on-failure --parallel "$(nproc)" "$@"
