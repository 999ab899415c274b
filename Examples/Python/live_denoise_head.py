"""Light the ch2 head MRI with a 360-degree camera's video and denoise it, in one VTK pipeline.

    PYTHONPATH=build/python /usr/bin/python3 Examples/Python/live_denoise_head.py CAMERA
        [--calibration ricoh-theta] [--size 240x156] [--frames 24] [--camera-wait 10]
        [--every-frame] [--output live]

The pipeline the headset's stream runs, built from HoloVolume's VTK classes:

    vtkPanoramaVideoSource -> vtkDualFisheyeToEquirectangular -> vtkEnvironmentSyncedLight
        -> vtkPathTracedVolumeMapper (its environment)  -> vtkStereoSpatioTemporalDenoiser
        -> (T, the illumination difference) ----------->   (its illumination input)

Each rendered frame takes the camera's next frame (waiting up to --camera-wait seconds for it;
0 takes the newest without waiting, as a live camera would), renders both eyes at 2 samples
per pixel and denoises them. The denoiser takes T from the synced light once per camera frame:
where the room's light changed it relights its history. Prints per frame the camera frame, T as
the denoiser took it, its temporal weight delta(1/(T-1)), the mean history length and the mean
radiance raw and denoised; writes the last frame's eyes as PNG. CAMERA is a dual-fisheye video
(or an image sequence, a device, a stream URL); holovolume-simulate-camera films one of an HDR
panorama, with a lamp that switches on, when no camera is at hand.
"""

import argparse
import sys

import holovolume
from head_scene import (HeadScene, add_scene_arguments, check_scene_arguments, display,
                        write_png)
from vtkmodules.util.misc import calldata_type
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.util.vtkConstants import VTK_STRING
from vtkmodules.vtkCommonMath import vtkMatrix4x4

# The mean radiance the first radiance map is scaled to, that of typical HDR panoramas (as
# holovolume's --environment-intensity auto does): a camera's recovered radiance is relative to
# its sensor's clip level, not absolute.
FIRST_MAP_MEAN_RADIANCE = 0.5

parser = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
parser.add_argument("camera", metavar="CAMERA",
                    help="dual-fisheye video file, image sequence, device or stream URL")
parser.add_argument("--calibration", default="ricoh-theta", metavar="PRESET",
                    help="the camera's lens preset: "
                    + ", ".join(holovolume.vtkDualFisheyeToEquirectangular.GetPresetName(i)
                                for i in range(
                                    holovolume.vtkDualFisheyeToEquirectangular.GetNumberOfPresets()))
                    + " [%(default)s]")
add_scene_arguments(parser, size="240x156")
parser.add_argument("--frames", type=int, default=24, metavar="N",
                    help="stereo frames to render [%(default)s]")
parser.add_argument("--camera-wait", type=float, default=10.0, metavar="S",
                    help="before each frame, wait up to S seconds for the camera's next frame; "
                    "0: take the newest without waiting [%(default)s]")
parser.add_argument("--every-frame", action="store_true",
                    help="a file: take its frames one after the other, none skipped however "
                    "long a frame renders (a recording processed offline); without it the file "
                    "plays at its frame rate, as a camera films, and frames that come while a "
                    "frame renders are skipped")
parser.add_argument("--output", default="live", metavar="PREFIX",
                    help="prefix of the PNG files [%(default)s]")
args = parser.parse_args()
width, height = check_scene_arguments(parser, args)
if args.frames < 1:
    parser.error(f"--frames {args.frames}: render at least one frame")
if args.camera_wait < 0:
    parser.error(f"--camera-wait {args.camera_wait}: give 0 or more seconds")

scene = HeadScene(args.volume, args.environment)
mapper = scene.mapper
errors = []


@calldata_type(VTK_STRING)
def on_error(caller, event, message):
    errors.append(f"{caller.GetClassName()}: {message.strip().splitlines()[-1]}")


source = holovolume.vtkPanoramaVideoSource()
source.SetSource(args.camera)
# A file plays at its frame rate, as a camera films: frames that come while a frame renders
# are skipped, unless --every-frame holds each one back until the pipeline took the last.
source.PaceToFrameRateOn()
source.SetDeliverEveryFrame(args.every_frame)
# Every rendered frame takes one camera frame, at its start, so that the whole chain sees it.
source.AutoAdvanceOff()
stitcher = holovolume.vtkDualFisheyeToEquirectangular()
stitcher.SetPreset(args.calibration)
stitcher.SetInputConnection(source.GetOutputPort())
synced = holovolume.vtkEnvironmentSyncedLight()
synced.SetInputConnection(stitcher.GetOutputPort())
for algorithm in (source, stitcher, synced):
    algorithm.AddObserver("ErrorEvent", on_error)
if not source.Open():
    sys.exit(f"cannot open the camera '{args.camera}': {errors[-1] if errors else 'see above'}")

# The synced light works in the room's frame, +Y up, in which an upright headset films the
# panorama; the head's world is that room turned by the mapper's EnvironmentToWorldMatrix
# (head_scene.py), so room = M^T world. The headset sits between the eyes, upright, its
# camera at its origin.
to_world = mapper.GetEnvironmentToWorldMatrix()


def to_room(point):
    return [sum(to_world.GetElement(j, i) * point[j] for j in range(3)) for i in range(3)]


centre = scene.centre
viewer = (centre[0], centre[1] + 600, centre[2] + 80)  # between the eyes (eye_matrices)
headset_pose = vtkMatrix4x4()
for i, value in enumerate(to_room(viewer)):
    headset_pose.SetElement(i, 3, value)
synced.SetHeadsetPose(headset_pose)
synced.SetVolumeCenter(*to_room(centre))
synced.SetProxyRadius(2500)  # the room's walls 2.5 m from the camera, in the volume's mm

mapper.SetEnvironmentMapConnection(synced.GetOutputPort())
# Fresh samples every frame (the denoiser accumulates over time), and each path also shaded
# under the previous radiance map, from which the denoiser relights its history when T says
# the light changed.
mapper.ProgressiveAccumulationOff()
mapper.RenderPreviousLightingOn()
synced.Update()
if errors:
    sys.exit(f"the lighting chain failed: {errors[0]}")
radiance = vtk_to_numpy(synced.GetOutput().GetPointData().GetArray("Radiance"))
mapper.SetEnvironmentIntensity(FIRST_MAP_MEAN_RADIANCE / max(float(radiance.mean()), 1e-6))

denoiser = holovolume.vtkStereoSpatioTemporalDenoiser()
denoiser.SetIlluminationConnection(synced.GetOutputPort())
denoiser.AddObserver("ErrorEvent", on_error)


def field(image, name):
    return image.GetFieldData().GetArray(name).GetValue(0)


def mean_radiance(image):
    values = vtk_to_numpy(image.GetPointData().GetArray("Radiance"))
    return float(values[:, :3].mean())


print(f"{args.frames} stereo frames of {width}x{height} per eye, 2 spp, lit by {args.camera}:")
print(f"  {'frame':>5s} {'camera':>6s} {'T':>6s} {'weight':>7s} {'history':>8s}"
      f" {'raw':>8s} {'denoised':>9s}")
for frame in range(args.frames):
    # Open() took the first camera frame.
    if frame > 0:
        if args.camera_wait > 0:
            source.WaitForNewFrame(args.camera_wait)
        else:
            source.UpdateToNewestFrame()
    matrices = scene.eye_matrices(width, height)
    if not mapper.RenderStereoFrame(scene.volume, *matrices, width, height) or errors:
        sys.exit(f"rendering failed: {errors[0] if errors else 'see the error above'}")
    denoiser.SetLeftEyeData(mapper.GetEyeOutput(0))
    denoiser.SetRightEyeData(mapper.GetEyeOutput(1))
    denoiser.Update()
    if errors:
        sys.exit(f"denoising failed: {errors[0]}")
    left = denoiser.GetEyeOutput(0)
    print(f"  {frame:5d} {source.GetFrameIndex():6d} {field(left, 'IlluminationDifference'):6.3f}"
          f" {field(left, 'TemporalWeight'):7.3f} {field(left, 'MeanHistoryLength'):8.2f}"
          f" {mean_radiance(mapper.GetEyeOutput(0)):8.4f} {mean_radiance(left):9.4f}")


for eye, name in ((0, "left"), (1, "right")):
    file_name = f"{args.output}-{name}.png"
    write_png(display(denoiser.GetEyeOutput(eye), mapper), file_name)
    print(f"wrote {file_name}")
