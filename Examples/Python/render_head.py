"""Path-trace the ch2 head MRI under an HDR panorama from Python and write both eyes as PNG.

    PYTHONPATH=build/python /usr/bin/python3 Examples/Python/render_head.py [--size 360x234] [--frames 8] [--output head]

Uses Debian's mricron-data (the volume) and blender-data (the panorama).
"""

import argparse
import sys

import holovolume
from vtkmodules.vtkCommonDataModel import vtkImageData, vtkPiecewiseFunction
from vtkmodules.vtkCommonMath import vtkMatrix4x4
from vtkmodules.vtkIOImage import vtkNIFTIImageReader, vtkPNGWriter
from vtkmodules.vtkRenderingCore import (
    vtkCamera,
    vtkColorTransferFunction,
    vtkVolume,
    vtkVolumeProperty,
)

parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
parser.add_argument("--volume", default="/usr/share/mricron/templates/ch2.nii.gz")
parser.add_argument("--environment",
                    default="/usr/share/blender/datafiles/studiolights/world/courtyard.exr")
parser.add_argument("--size", default="360x234", help="pixels per eye, WIDTHxHEIGHT")
parser.add_argument("--frames", type=int, default=8, help="progressive frames of 2 samples")
parser.add_argument("--output", default="head", help="prefix of the PNG files")
args = parser.parse_args()
width, height = (int(v) for v in args.size.split("x"))

reader = vtkNIFTIImageReader()
reader.SetFileName(args.volume)
environment = holovolume.vtkEnvironmentMapReader()
environment.SetFileName(args.environment)

mapper = holovolume.vtkPathTracedVolumeMapper()
mapper.SetInputConnection(reader.GetOutputPort())
mapper.SetEnvironmentMapConnection(environment.GetOutputPort())
# The panorama's +Y (zenith) becomes the head's +Z (superior).
to_world = vtkMatrix4x4()
to_world.DeepCopy((1, 0, 0, 0, 0, 0, -1, 0, 0, 1, 0, 0, 0, 0, 0, 1))
mapper.SetEnvironmentToWorldMatrix(to_world)

opacity = vtkPiecewiseFunction()
for scalar, value in ((0, 0.0), (28, 0.0), (40, 0.9), (255, 0.98)):
    opacity.AddPoint(scalar, value)
color = vtkColorTransferFunction()
color.AddRGBPoint(0, 0.85, 0.62, 0.52)
color.AddRGBPoint(140, 0.97, 0.93, 0.88)
color.AddRGBPoint(255, 1.0, 1.0, 1.0)
prop = vtkVolumeProperty()
prop.SetScalarOpacity(opacity)
prop.SetColor(color)
volume = vtkVolume()
volume.SetMapper(mapper)
volume.SetProperty(prop)

reader.Update()
x0, x1, y0, y1, z0, z1 = reader.GetOutput().GetBounds()
centre = ((x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2)
matrices = []
for offset in (-32.0, 32.0):  # eyes 64 mm apart, looking at the face
    camera = vtkCamera()
    camera.SetFocalPoint(centre[0] + offset, centre[1], centre[2])
    camera.SetPosition(centre[0] + offset, centre[1] + 600, centre[2] + 80)
    camera.SetViewUp(0, 0, 1)
    camera.SetViewAngle(30)
    camera.SetClippingRange(300, 900)
    view, projection = vtkMatrix4x4(), vtkMatrix4x4()
    view.DeepCopy(camera.GetModelViewTransformMatrix())
    projection.DeepCopy(camera.GetProjectionTransformMatrix(width / height, -1, 1))
    matrices += [view, projection]

for frame in range(args.frames):
    if not mapper.RenderStereoFrame(volume, *matrices, width, height):
        sys.exit("rendering failed (see the error above)")

for eye, name in ((0, "left"), (1, "right")):
    image = vtkImageData()
    mapper.ComputeDisplayImage(eye, image)
    writer = vtkPNGWriter()
    writer.SetInputData(image)
    writer.SetFileName(f"{args.output}-{name}.png")
    writer.Write()
    print(f"wrote {args.output}-{name}.png ({mapper.GetAccumulatedFrames(eye)} frames)")
