"""Denoise 2-spp stereo frames of the ch2 head MRI from Python and compare with a reference.

    PYTHONPATH=build/python /usr/bin/python3 Examples/Python/denoise_head.py
        [--size 360x234] [--frames 16] [--orbit 0] [--reference-spp 256] [--output head]

Renders --frames stereo frames of 2 samples per pixel (a fresh frame each time, as in the
headset), feeds each pair with its auxiliary buffers to vtkStereoSpatioTemporalDenoiser, and
writes the last frame's eyes raw and denoised as PNG. With --reference-spp it also path-traces
the last frame to that many samples per pixel (with independent random numbers) and prints each
eye's PSNR of the display values, raw and denoised. Uses Debian's mricron-data (the volume) and
blender-data (the panorama).
"""

import argparse
import math
import sys

import holovolume
import numpy as np
from head_scene import (HeadScene, add_scene_arguments, check_scene_arguments, display,
                        write_png)
from vtkmodules.util.misc import calldata_type
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.util.vtkConstants import VTK_STRING

parser = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
add_scene_arguments(parser)
parser.add_argument("--frames", type=int, default=16, metavar="N",
                    help="stereo frames of 2 spp the denoiser sees [%(default)s]")
parser.add_argument("--orbit", type=float, default=0.0, metavar="DEGREES",
                    help="degrees the eyes turn about the head per frame [%(default)s]")
parser.add_argument("--reference-spp", type=int, default=256, metavar="N",
                    help="samples per pixel of the last frame's reference; 0: none [%(default)s]")
parser.add_argument("--require-gain", type=float, metavar="DB",
                    help="exit with status 1 unless the denoised eyes beat the raw ones by DB")
parser.add_argument("--output", default="head", metavar="PREFIX",
                    help="prefix of the PNG files [%(default)s]")
args = parser.parse_args()
width, height = check_scene_arguments(parser, args)
if args.frames < 1:
    parser.error(f"--frames {args.frames}: the denoiser needs at least one frame")
if args.reference_spp < 0 or (args.require_gain is not None and args.reference_spp == 0):
    parser.error("--reference-spp must be positive (and is needed by --require-gain)")

scene = HeadScene(args.volume, args.environment)
mapper = scene.mapper
# The denoiser accumulates over time itself: every frame is 2 fresh samples per pixel.
mapper.ProgressiveAccumulationOff()
denoiser = holovolume.vtkStereoSpatioTemporalDenoiser()
# A still panorama: the lighting does not change between frames (T = 0). With a live one,
# connect vtkEnvironmentSyncedLight's output with SetIlluminationConnection() instead.
denoiser.SetIlluminationDifference(0.0)
# The filter reports bad input (eyes of different sizes, a missing buffer, NaN radiance) with
# vtkErrorMacro and produces no image; an observer turns that into the script's exit.
denoiser_errors = []


@calldata_type(VTK_STRING)
def on_denoiser_error(caller, event, message):
    denoiser_errors.append(message.strip().splitlines()[-1])


denoiser.AddObserver("ErrorEvent", on_denoiser_error)

print(f"{args.frames} stereo frames of {width}x{height} per eye, 2 spp:")
for frame in range(args.frames):
    matrices = scene.eye_matrices(width, height, frame * args.orbit)
    if not mapper.RenderStereoFrame(scene.volume, *matrices, width, height):
        sys.exit("rendering failed (see the error above)")
    denoiser.SetLeftEyeData(mapper.GetEyeOutput(0))
    denoiser.SetRightEyeData(mapper.GetEyeOutput(1))
    denoiser.Update()
    if denoiser_errors:
        sys.exit(f"denoising failed: {denoiser_errors[0]}")
    fields = denoiser.GetEyeOutput(0).GetFieldData()
    history = fields.GetArray("MeanHistoryLength").GetValue(0)
    disoccluded = 100 * fields.GetArray("DisoccludedFraction").GetValue(0)
    print(f"  frame {frame:3d}: mean history {history:5.1f} frames,"
          f" disoccluded {disoccluded:5.1f} % (left eye)")


def display_rgb(image):
    """Display values in [0, 1], RGB over black (premultiplied), as a numpy array."""
    values = vtk_to_numpy(image.GetPointData().GetArray("DisplayRGBA"))
    return values[:, :3].astype(np.float64) / 255.0


eyes = {}
for eye, name in ((0, "left"), (1, "right")):
    eyes[name] = {
        "raw": display(mapper.GetEyeOutput(eye), mapper),
        "denoised": display(denoiser.GetEyeOutput(eye), mapper),
    }
    for kind, image in eyes[name].items():
        file_name = f"{args.output}-{name}{'' if kind == 'denoised' else '-raw'}.png"
        write_png(image, file_name)
        print(f"wrote {file_name}")

if args.reference_spp == 0:
    sys.exit(0)

# The reference: the last frame's view, accumulated progressively by the same mapper with other
# random numbers (the changed settings restart its accumulation; the raw and denoised display
# images above are copies and stay as they are).
mapper.SetSeed(mapper.GetSeed() + 7919)
mapper.SetSamplesPerPixel(min(args.reference_spp, 16))
mapper.ProgressiveAccumulationOn()
passes = math.ceil(args.reference_spp / mapper.GetSamplesPerPixel())
print(f"reference: {passes * mapper.GetSamplesPerPixel()} spp", end="", flush=True)
for _ in range(passes):
    if not mapper.RenderStereoFrame(scene.volume, *matrices, width, height):
        sys.exit("\nrendering the reference failed (see the error above)")
    print(".", end="", flush=True)
print()


def psnr(image, truth_rgb):
    mse = np.mean((display_rgb(image) - truth_rgb) ** 2)
    return math.inf if mse == 0 else 10 * math.log10(1 / mse)


print("PSNR of the display values against the reference (dB):")
print(f"  {'eye':6s} {'raw 2 spp':>10s} {'denoised':>10s} {'gain':>7s}")
gains = []
for eye, name in ((0, "left"), (1, "right")):
    truth = display_rgb(display(mapper.GetEyeOutput(eye), mapper))
    raw = psnr(eyes[name]["raw"], truth)
    denoised = psnr(eyes[name]["denoised"], truth)
    gains.append(denoised - raw)
    print(f"  {name:6s} {raw:10.2f} {denoised:10.2f} {denoised - raw:+7.2f}")

if args.require_gain is not None and min(gains) < args.require_gain:
    sys.exit(f"the denoised eyes gain {min(gains):.2f} dB over raw 2 spp, less than the "
             f"{args.require_gain:.2f} dB --require-gain asks for")
