"""Checks Examples/Python/live_denoise_head.py on a clip whose lamp switches on.

    check_python_live_denoise.py SWITCH_CAMERA_FRAME -- PYTHON EXAMPLE ARGUMENTS...

Runs the example (the VTK pipeline camera -> stitcher -> vtkEnvironmentSyncedLight -> mapper,
with the synced light's output as the denoiser's illumination input) and reads its table. The
denoiser takes T from that input once per camera frame, so the test asks that:

- after the first frame and before the switch, T stays below 0.05 and the history grows;
- on the first frame from the switch on, T is at least 0.2, the temporal weight delta(1/(T-1))
  below 0.01, and the history is kept (relit) rather than dropped;
- on the frames after it T is below 0.05 again: the lamp's T counted once;
- from the switch on the denoised frame's mean radiance stays within 20 % of the raw frame's,
  which the lamp brightens by more than half;
- both eyes' PNG files were written;
- with --every-frame, rendered frame i took camera frame i: none skipped, none taken twice.
"""
import os
import re
import subprocess
import sys

from live_switch_checks import (every_frame_errors, follows_light_errors, history_errors,
                                split_at_switch)

ROW = re.compile(r"^ +(\d+) +(\d+) +([0-9.]+) +([0-9.]+) +([0-9.]+) +([0-9.]+) +([0-9.]+)$",
                 re.MULTILINE)


def main():
    separator = sys.argv.index("--")
    switch_frame = int(sys.argv[1])
    command = sys.argv[separator + 1:]
    output = command[command.index("--output") + 1]
    total = int(command[command.index("--frames") + 1])
    run = subprocess.run(command, capture_output=True, text=True)
    print(run.stdout)
    if run.returncode != 0:
        print(run.stderr)
        return f"the example exited with status {run.returncode}"

    frames = [{"frame": int(m[1]), "camera": int(m[2]), "T": float(m[3]), "weight": float(m[4]),
               "history": float(m[5]), "raw": float(m[6]), "denoised": float(m[7])}
              for m in ROW.finditer(run.stdout)]
    if len(frames) != total:
        return f"expected {total} rows of the per-frame table, read {len(frames)}"
    errors = []
    if "--every-frame" in command:
        errors += every_frame_errors(frames, camera_offset=0)
    before, after = split_at_switch(frames, switch_frame)
    if not before or len(after) < 2:
        return f"the clip did not cover the switch at camera frame {switch_frame}"
    for f in before:
        if f["T"] >= 0.05:
            errors.append(f"frame {f['frame']}: T {f['T']} before the lamp")
    switch = after[0]
    if switch["T"] < 0.2 or switch["weight"] > 0.01:
        errors.append(f"frame {switch['frame']}: the lamp gave T {switch['T']} and temporal "
                      f"weight {switch['weight']}, not T >= 0.2 and a weight below 0.01")
    for f in after[1:]:
        if f["T"] >= 0.05:
            errors.append(f"frame {f['frame']}: T {f['T']} after the lamp, which counts once")
    errors += history_errors(before, switch)
    errors += follows_light_errors(before, after)
    for name in ("left", "right"):
        if not os.path.isfile(f"{output}-{name}.png"):
            errors.append(f"{output}-{name}.png was not written")
    if errors:
        return "\n".join(errors)
    print("the pipeline's denoiser takes the lamp's T once and follows the new light")
    return 0


if __name__ == "__main__":
    sys.exit(main())
