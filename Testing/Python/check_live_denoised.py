"""Checks holovolume's live mode with --denoise on a clip whose lamp switches on.

    check_live_denoised.py HOLOVOLUME SWITCH_CAMERA_FRAME -- ARGUMENTS...

Runs HOLOVOLUME ARGUMENTS (live mode, --denoise, --save-frames) and reads its per-frame lines.
The lamp brightens the rendered frame (raw, 2 spp) by more than half, so a denoiser that kept
its history under the old light would lag far behind it: given T = 0 instead of the maps'
difference (a trial build), the denoised frames had 0.58, 0.67, 0.79 and 0.83 of the raw
radiance on the lamp's frame and the three after it. The test asks that:

- before the switch the radiance map is kept and the denoiser's history grows;
- on the first frame from the switch on the map is replaced with an illumination difference
  T of at least 0.2, and the history is kept (relit) rather than dropped;
- from the switch on the denoised frame's mean radiance stays within 20 % of the raw frame's
  (the raw frames' own spread at 48x32 is about 5 %);
- the denoised images, and a raw and a denoised image per rendered frame, were written;
- with --camera-every-frame, rendered frame i (counted from 1) took camera frame i - 1.
"""
import os
import re
import subprocess
import sys

from live_switch_checks import (every_frame_errors, follows_light_errors, history_errors,
                                split_at_switch)

LINE = re.compile(
    r"frame +(\d+)/(\d+) +camera frame (\d+)(?: \(same\))? +T ([0-9.]+) .*? "
    r"(map replaced|map kept) +denoise [0-9.]+ ms +history ([0-9.]+) frames +"
    r"temporal weight ([0-9.]+) +radiance raw ([0-9.]+) denoised ([0-9.]+)")


def main():
    separator = sys.argv.index("--")
    holovolume, switch_frame = sys.argv[1], int(sys.argv[2])
    arguments = sys.argv[separator + 1:]
    output = arguments[arguments.index("--output") + 1]
    run = subprocess.run([holovolume] + arguments, capture_output=True, text=True)
    print(run.stdout)
    if run.returncode != 0:
        print(run.stderr)
        return f"holovolume exited with status {run.returncode}"

    frames = []
    for match in LINE.finditer(run.stdout):
        frames.append({
            "frame": int(match[1]), "camera": int(match[3]), "T": float(match[4]),
            "replaced": match[5] == "map replaced", "history": float(match[6]),
            "raw": float(match[8]), "denoised": float(match[9])})
    total = int(arguments[arguments.index("--camera-frames") + 1])
    if len(frames) != total:
        return f"expected {total} per-frame lines with the denoiser's figures, read {len(frames)}"

    errors = []
    if "--camera-every-frame" in arguments:
        errors += every_frame_errors(frames, camera_offset=-1)
    before, after = split_at_switch(frames, switch_frame)
    if not before or not after:
        return f"the clip did not cover the switch at camera frame {switch_frame}"
    for f in before:
        if f["replaced"]:
            errors.append(f"frame {f['frame']}: the map was replaced before the lamp (T {f['T']})")
    switch = after[0]
    if not switch["replaced"] or switch["T"] < 0.2:
        errors.append(f"frame {switch['frame']}: the lamp did not replace the map with T >= 0.2")
    errors += history_errors(before, switch)
    errors += follows_light_errors(before, after)

    for name in ("left", "right", "stereo"):
        path = os.path.join(output, f"live-path-traced-denoised-{name}.png")
        if not os.path.isfile(path):
            errors.append(f"{path} was not written")
    for frame in range(1, total + 1):
        for kind in ("", "-denoised"):
            path = os.path.join(output, "frames", f"live-path-traced{kind}-{frame:04d}.png")
            if not os.path.isfile(path):
                errors.append(f"{path} was not written")
    if errors:
        return "\n".join(errors)
    print("live denoising follows the lamp")
    return 0


if __name__ == "__main__":
    sys.exit(main())
