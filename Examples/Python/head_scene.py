"""The scene the Python examples share: the ch2 head MRI under an HDR panorama, two eyes.

Uses Debian's mricron-data (the volume) and blender-data (the panorama); any NIfTI volume
and equirectangular EXR/HDR panorama can stand in for them.
"""

import os
import sys

import holovolume
from vtkmodules.vtkCommonDataModel import vtkImageData, vtkPiecewiseFunction
from vtkmodules.vtkCommonMath import vtkMatrix4x4
from vtkmodules.vtkCommonTransforms import vtkTransform
from vtkmodules.vtkIOImage import vtkNIFTIImageReader, vtkPNGWriter
from vtkmodules.vtkRenderingCore import (
    vtkCamera,
    vtkColorTransferFunction,
    vtkVolume,
    vtkVolumeProperty,
)

DEFAULT_VOLUME = "/usr/share/mricron/templates/ch2.nii.gz"
DEFAULT_ENVIRONMENT = "/usr/share/blender/datafiles/studiolights/world/courtyard.exr"


def add_scene_arguments(parser, size="360x234"):
    parser.add_argument("--volume", default=DEFAULT_VOLUME, metavar="FILE",
                        help="NIfTI volume [%(default)s]")
    parser.add_argument("--environment", default=DEFAULT_ENVIRONMENT, metavar="FILE",
                        help="equirectangular HDR panorama [%(default)s]")
    parser.add_argument("--size", default=size, metavar="WxH",
                        help="pixels per eye, WIDTHxHEIGHT [%(default)s]")


def check_scene_arguments(parser, args):
    """Stops with a message that says what to do when an input file is missing."""
    for option, path, package in (("--volume", args.volume, "mricron-data"),
                                  ("--environment", args.environment, "blender-data")):
        if not os.path.isfile(path):
            hint = f" (apt-get install {package}, or pass {option} FILE)" if path in (
                DEFAULT_VOLUME, DEFAULT_ENVIRONMENT) else ""
            parser.error(f"{option} '{path}' does not exist{hint}")
    return parse_size(parser, args.size)


def parse_size(parser, text):
    try:
        width, height = (int(v) for v in text.split("x"))
    except ValueError:
        parser.error(f"--size '{text}' is not WIDTHxHEIGHT, e.g. 360x234")
    if width < 8 or height < 8:
        parser.error(f"--size '{text}': each eye needs at least 8x8 pixels")
    return width, height


def write_png(image, file_name):
    """Writes a display image; exits with the reason when the file cannot be written."""
    writer = vtkPNGWriter()
    writer.SetInputData(image)
    writer.SetFileName(file_name)
    writer.Write()
    if writer.GetErrorCode():
        sys.exit(f"could not write {file_name} (see the error above)")


def display(radiance_image, tone_mapper):
    """The tone-mapped, sRGB-encoded image of a radiance image (premultiplied RGBA bytes)."""
    image = vtkImageData()
    if not tone_mapper.ComputeDisplayImage(radiance_image, image):
        sys.exit("tone mapping failed (see the error above)")
    return image


class HeadScene:
    """Reader, panorama, path-tracing mapper and volume of the head, ready to render."""

    def __init__(self, volume_file, environment_file):
        self.reader = vtkNIFTIImageReader()
        self.reader.SetFileName(volume_file)
        self.environment = holovolume.vtkEnvironmentMapReader()
        self.environment.SetFileName(environment_file)

        self.mapper = holovolume.vtkPathTracedVolumeMapper()
        self.mapper.SetInputConnection(self.reader.GetOutputPort())
        self.mapper.SetEnvironmentMapConnection(self.environment.GetOutputPort())
        # The panorama's +Y (zenith) becomes the head's +Z (superior).
        to_world = vtkMatrix4x4()
        to_world.DeepCopy((1, 0, 0, 0, 0, 0, -1, 0, 0, 1, 0, 0, 0, 0, 0, 1))
        self.mapper.SetEnvironmentToWorldMatrix(to_world)

        # Air and background transparent, skin and brain nearly opaque (ch2's scalars: 0-255).
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
        self.volume = vtkVolume()
        self.volume.SetMapper(self.mapper)
        self.volume.SetProperty(prop)

        self.reader.Update()
        x0, x1, y0, y1, z0, z1 = self.reader.GetOutput().GetBounds()
        self.centre = ((x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2)

    def eye_matrices(self, width, height, azimuth=0.0):
        """View and projection matrices of both eyes, 64 mm apart, looking at the face.

        azimuth (degrees) turns the pair of eyes about the head's vertical axis.
        """
        orbit = vtkTransform()
        orbit.Translate(self.centre)
        orbit.RotateZ(azimuth)
        orbit.Translate(-self.centre[0], -self.centre[1], -self.centre[2])
        matrices = []
        for offset in (-32.0, 32.0):
            focal_point = (self.centre[0] + offset, self.centre[1], self.centre[2])
            position = (self.centre[0] + offset, self.centre[1] + 600, self.centre[2] + 80)
            camera = vtkCamera()
            camera.SetFocalPoint(orbit.TransformPoint(focal_point))
            camera.SetPosition(orbit.TransformPoint(position))
            camera.SetViewUp(0, 0, 1)
            camera.SetViewAngle(30)
            camera.SetClippingRange(300, 900)
            view, projection = vtkMatrix4x4(), vtkMatrix4x4()
            view.DeepCopy(camera.GetModelViewTransformMatrix())
            projection.DeepCopy(camera.GetProjectionTransformMatrix(width / height, -1, 1))
            matrices += [view, projection]
        return matrices
