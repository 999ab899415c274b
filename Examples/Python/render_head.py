"""Path-trace the ch2 head MRI under an HDR panorama from Python and write both eyes as PNG.

    PYTHONPATH=build/python /usr/bin/python3 Examples/Python/render_head.py
        [--size 360x234] [--frames 8] [--output head]

Uses Debian's mricron-data (the volume) and blender-data (the panorama).
"""

import argparse
import sys

from head_scene import HeadScene, add_scene_arguments, check_scene_arguments, write_png
from vtkmodules.vtkCommonDataModel import vtkImageData

parser = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
add_scene_arguments(parser)
parser.add_argument("--frames", type=int, default=8, metavar="N",
                    help="progressive frames of 2 samples [%(default)s]")
parser.add_argument("--output", default="head", metavar="PREFIX",
                    help="prefix of the PNG files [%(default)s]")
args = parser.parse_args()
width, height = check_scene_arguments(parser, args)

scene = HeadScene(args.volume, args.environment)
matrices = scene.eye_matrices(width, height)
for frame in range(args.frames):
    if not scene.mapper.RenderStereoFrame(scene.volume, *matrices, width, height):
        sys.exit("rendering failed (see the error above)")

for eye, name in ((0, "left"), (1, "right")):
    image = vtkImageData()
    scene.mapper.ComputeDisplayImage(eye, image)
    write_png(image, f"{args.output}-{name}.png")
    print(f"wrote {args.output}-{name}.png ({scene.mapper.GetAccumulatedFrames(eye)} frames)")
