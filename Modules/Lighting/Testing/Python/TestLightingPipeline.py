"""The live-lighting pipeline from Python: camera frames from files through
vtkPanoramaVideoSource, stitching with a camera preset, and vtkEnvironmentSyncedLight's HDR
radiance map, illumination difference and detected lights. Runs with Debian's
/usr/bin/python3 (the one with vtkmodules)."""

import math
import os
import sys
import unittest

import holovolume
from vtkmodules.vtkCommonCore import vtkCommand, vtkUnsignedCharArray
from vtkmodules.vtkCommonDataModel import vtkImageData
from vtkmodules.vtkIOImage import vtkPNGWriter

OUTPUT_DIRECTORY = sys.argv.pop(1) if len(sys.argv) > 1 else "."


def room_panorama(width, lamp_on):
    """An 8-bit equirectangular room (sRGB code 90) with, if lit, a clipped ceiling lamp
    of 30 degrees radius with a soft 10-degree rim (what a lens's glare leaves around it)."""
    height = width // 2
    image = vtkImageData()
    image.SetDimensions(width, height, 1)
    codes = vtkUnsignedCharArray()
    codes.SetNumberOfComponents(3)
    codes.SetNumberOfTuples(width * height)
    for j in range(height):
        polar = (1.0 - (j + 0.5) / height) * 180.0  # VTK rows run from the nadir up
        value = 90
        if lamp_on and polar < 40.0:
            value = 255 if polar < 30.0 else int(90 + 165 * (40.0 - polar) / 10.0)
        for i in range(width):
            codes.SetTuple3(j * width + i, value, value, value)
    image.GetPointData().SetScalars(codes)
    return image


class ErrorObserver:
    def __init__(self):
        self.messages = []

    def __call__(self, caller, event, data=None):
        self.messages.append(str(data))


class LightingPipelineTest(unittest.TestCase):
    def test_package_exports_the_lighting_classes(self):
        for name in ("vtkPanoramaVideoSource", "vtkDualFisheyeToEquirectangular",
                     "vtkEnvironmentSyncedLight"):
            self.assertIn(name, holovolume.__all__)

    def test_frames_from_files_to_radiance_map(self):
        # Two frames of an equirectangular camera written as a numbered PNG sequence.
        writer = vtkPNGWriter()
        for index, lamp_on in enumerate((False, True)):
            writer.SetInputData(room_panorama(128, lamp_on))
            writer.SetFileName(os.path.join(OUTPUT_DIRECTORY, "room_%02d.png" % index))
            writer.Write()
        source = holovolume.vtkPanoramaVideoSource()
        source.SetSource(os.path.join(OUTPUT_DIRECTORY, "room_%02d.png"))
        # Two frames a second, so that the first Update() sees the first frame.
        source.SetPaceToFrameRate(True)
        source.SetDefaultFrameRate(2.0)
        source.SetAutoAdvance(False)
        light = holovolume.vtkEnvironmentSyncedLight()
        light.SetInputConnection(source.GetOutputPort())
        light.SetOutputHeight(64)
        light.Update()
        radiance = light.GetOutput().GetPointData().GetArray("Radiance")
        self.assertEqual(light.GetOutput().GetDimensions(), (128, 64, 1))
        self.assertEqual(radiance.GetNumberOfComponents(), 3)
        first_t = light.GetIlluminationDifference()
        self.assertGreater(first_t, 0.99)  # no history yet

        # The lamp switches on in the next frame: T rises, the lamp is detected overhead.
        self.assertTrue(source.WaitForNewFrame(5.0))
        light.Update()
        self.assertGreater(light.GetIlluminationDifference(), 0.5)
        t_field = light.GetOutput().GetFieldData().GetArray("IlluminationDifference")
        self.assertAlmostEqual(t_field.GetValue(0), light.GetIlluminationDifference())
        lights = light.GetDetectedLights()
        self.assertGreaterEqual(lights.GetNumberOfPoints(), 1)
        direction = lights.GetPointData().GetArray("Direction").GetTuple3(0)
        self.assertGreater(direction[1], math.cos(math.radians(10.0)))

    def test_stitcher_rejects_a_frame_of_the_wrong_shape(self):
        stitcher = holovolume.vtkDualFisheyeToEquirectangular()
        stitcher.SetPreset("ricoh-theta")
        frame = vtkImageData()
        frame.SetDimensions(100, 100, 1)
        frame.AllocateScalars(3, 3)  # VTK_UNSIGNED_CHAR
        stitcher.SetInputData(frame)
        errors = ErrorObserver()
        stitcher.AddObserver(vtkCommand.ErrorEvent, errors)
        stitcher.GetExecutive().AddObserver(vtkCommand.ErrorEvent, ErrorObserver())
        stitcher.Update()
        self.assertTrue(errors.messages, "a square frame must be reported")


if __name__ == "__main__":
    unittest.main()
