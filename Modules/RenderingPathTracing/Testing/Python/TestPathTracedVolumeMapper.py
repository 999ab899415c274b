"""The wrapped package `holovolume` from Python: build a pipeline, render both eyes
off-screen, read the HDR radiance and the auxiliary buffers, and get a clear error for
bad input. Runs with Debian's /usr/bin/python3 (the one with vtkmodules)."""

import math
import sys
import unittest

import holovolume
from vtkmodules.vtkCommonCore import vtkCommand
from vtkmodules.vtkCommonDataModel import vtkImageData, vtkPiecewiseFunction
from vtkmodules.vtkImagingCore import vtkRTAnalyticSource
from vtkmodules.vtkRenderingCore import (
    vtkCamera,
    vtkColorTransferFunction,
    vtkVolume,
    vtkVolumeProperty,
)


def make_scene():
    source = vtkRTAnalyticSource()  # smooth synthetic blob, scalars ~37..277
    source.SetWholeExtent(-16, 16, -16, 16, -16, 16)
    mapper = holovolume.vtkPathTracedVolumeMapper()
    mapper.SetInputConnection(source.GetOutputPort())
    opacity = vtkPiecewiseFunction()
    opacity.AddPoint(37, 0.0)
    opacity.AddPoint(160, 0.0)
    opacity.AddPoint(220, 0.9)
    opacity.AddPoint(277, 0.9)
    color = vtkColorTransferFunction()
    color.AddRGBPoint(37, 0.9, 0.6, 0.4)
    color.AddRGBPoint(277, 1.0, 1.0, 1.0)
    prop = vtkVolumeProperty()
    prop.SetScalarOpacity(opacity)
    prop.SetColor(color)
    volume = vtkVolume()
    volume.SetMapper(mapper)
    volume.SetProperty(prop)
    return source, mapper, volume


def eye_matrices(offset, aspect):
    camera = vtkCamera()
    camera.SetPosition(offset, 0, 70)
    camera.SetFocalPoint(offset, 0, 0)
    camera.SetClippingRange(20, 120)
    return (camera.GetModelViewTransformMatrix(),
            camera.GetProjectionTransformMatrix(aspect, -1, 1))


class PathTracedVolumeMapperTest(unittest.TestCase):
    def test_stereo_buffers(self):
        source, mapper, volume = make_scene()
        width, height = 40, 30
        left = eye_matrices(-1.0, width / height)
        right = eye_matrices(1.0, width / height)
        self.assertEqual(mapper.RenderStereoFrame(volume, left[0], left[1], right[0], right[1],
                                                  width, height), 1)
        for eye in (0, 1):
            image = mapper.GetEyeOutput(eye)
            self.assertEqual(image.GetDimensions(), (width, height, 1))
            pd = image.GetPointData()
            for name, components in (("Radiance", 4), ("FirstScatterPosition", 3), ("Depth", 1),
                                     ("Albedo", 3), ("Normal", 3), ("GradientMagnitude", 1),
                                     ("FirstScatterValid", 1)):
                array = pd.GetArray(name)
                self.assertIsNotNone(array, name)
                self.assertEqual(array.GetNumberOfComponents(), components, name)
            self.assertEqual(image.GetFieldData().GetArray("Eye").GetValue(0), eye)
            self.assertEqual(image.GetFieldData().GetArray("ViewMatrix").GetNumberOfTuples(), 16)
            # The blob is in view: some pixels scattered, and their depth is in front of the eye.
            valid = pd.GetArray("FirstScatterValid")
            covered = sum(valid.GetValue(i) for i in range(valid.GetNumberOfTuples()))
            self.assertGreater(covered, width * height // 10)
            self.assertGreater(pd.GetArray("Depth").GetRange()[1], 20.0)
            radiance = pd.GetArray("Radiance")
            self.assertTrue(all(math.isfinite(radiance.GetComponent(i, c))
                                for i in range(radiance.GetNumberOfTuples()) for c in range(4)))
        self.assertEqual(mapper.GetFrameIndex(), 1)

    def test_previous_lighting(self):
        source, mapper, volume = make_scene()
        mapper.SetRenderPreviousLighting(True)
        mapper.ProgressiveAccumulationOff()
        left = eye_matrices(-1.0, 1.0)
        right = eye_matrices(1.0, 1.0)

        def render(intensity):
            mapper.SetEnvironmentIntensity(intensity)
            self.assertEqual(mapper.RenderStereoFrame(volume, left[0], left[1], right[0],
                                                      right[1], 24, 24), 1)
            return mapper.GetEyeOutput(1).GetPointData()

        self.assertIsNone(render(1.0).GetArray("PreviousLightingRadiance"))
        points = render(0.5)
        previous = points.GetArray("PreviousLightingRadiance")
        self.assertIsNotNone(previous)
        radiance = points.GetArray("Radiance")
        # Half the intensity, the same paths: the previous light is twice the radiance.
        for i in range(radiance.GetNumberOfTuples()):
            for c in range(3):
                self.assertAlmostEqual(previous.GetComponent(i, c),
                                       2.0 * radiance.GetComponent(i, c), places=5)
        self.assertIsNone(render(0.5).GetArray("PreviousLightingRadiance"))
        self.assertIn("RenderPreviousLighting: On", str(mapper))

    def test_display_image_and_models(self):
        source, mapper, volume = make_scene()
        view, projection = eye_matrices(0.0, 1.0)
        display = vtkImageData()
        for model in (mapper.EMISSION_ABSORPTION, mapper.GRADIENT_PHONG,
                      mapper.PREFILTERED_ENVIRONMENT, mapper.PATH_TRACED):
            mapper.SetIlluminationModel(model)
            self.assertEqual(mapper.RenderEye(volume, 0, view, projection, 24, 24), 1)
            self.assertEqual(mapper.ComputeDisplayImage(0, display), 1)
            self.assertEqual(display.GetPointData().GetScalars().GetNumberOfComponents(), 4)
            self.assertGreater(display.GetPointData().GetScalars().GetRange(3)[1], 0)
        self.assertEqual(mapper.GetIlluminationModelAsString(), "PathTraced")
        self.assertIn("IlluminationModel: PathTraced", str(mapper))  # PrintSelf

    def test_bad_input_reports_error(self):
        mapper = holovolume.vtkPathTracedVolumeMapper()
        volume = vtkVolume()
        volume.SetMapper(mapper)
        messages = []
        mapper.AddObserver(vtkCommand.ErrorEvent, lambda caller, event: messages.append(event))
        view, projection = eye_matrices(0.0, 1.0)
        self.assertEqual(mapper.RenderEye(volume, 0, view, projection, 8, 8), 0)
        self.assertTrue(messages, "no error reported for a mapper without input")

    def test_reader_class_is_wrapped(self):
        reader = holovolume.vtkEnvironmentMapReader()
        reader.SetFileName("/nonexistent/panorama.exr")
        messages = []
        reader.AddObserver(vtkCommand.ErrorEvent, lambda caller, event: messages.append(event))
        reader.Update()
        self.assertTrue(messages)


if __name__ == "__main__":
    result = unittest.main(exit=False, verbosity=2).result
    sys.exit(0 if result.wasSuccessful() else 1)
