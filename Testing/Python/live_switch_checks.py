"""What the live-denoising checks ask of a clip whose lamp switches on.

Shared by check_live_denoised.py (the holovolume application) and
check_python_live_denoise.py (the Python example). Each frame is a dict with at least
"frame", "camera", "history", "raw" and "denoised"; each function returns a list of errors.
"""


def every_frame_errors(frames, camera_offset):
    """Rendered frame f must take camera frame f + camera_offset: none skipped, none taken
    twice (what a source that delivers every frame promises)."""
    skipped = [(f["frame"], f["camera"]) for f in frames
               if f["camera"] != f["frame"] + camera_offset]
    if not skipped:
        return []
    return ["with every camera frame delivered each rendered frame takes the next camera frame; "
            f"(rendered, camera) frames {skipped} do not"]


def split_at_switch(frames, switch_frame):
    """The frames after the first whose camera frame is before the lamp, and those from it."""
    before = [f for f in frames[1:] if f["camera"] < switch_frame]
    after = [f for f in frames if f["camera"] >= switch_frame]
    return before, after


def history_errors(before, switch):
    """The history grows before the lamp and is relit, not dropped, on its frame."""
    errors = []
    if before[-1]["history"] < 1.5:
        errors.append(f"the history did not grow before the lamp ({before[-1]['history']} frames)")
    if switch["history"] < 1.5:
        errors.append(f"frame {switch['frame']}: the history was dropped instead of relit "
                      f"({switch['history']} frames)")
    return errors


def follows_light_errors(before, after):
    """From the lamp on the denoised frame's mean radiance stays within 20 % of the raw frame's,
    which the lamp must brighten by more than half for the test to tell a relit history from a
    stale one."""
    errors = []
    if after[0]["raw"] < 1.5 * before[-1]["raw"]:
        errors.append("the lamp brightens the raw frame by less than half: the radiance check "
                      "would not tell a relit history from a stale one")
    for f in after:
        ratio = f["denoised"] / f["raw"]
        print(f"frame {f['frame']} (camera frame {f['camera']}): denoised / raw radiance "
              f"{ratio:.3f}, history {f['history']} frames")
        if not 0.8 <= ratio <= 1.2:
            errors.append(f"frame {f['frame']}: denoised / raw radiance {ratio:.3f}, not within "
                          "20 %: the denoised frame does not follow the new light")
    return errors
