"""The denoiser from Python: the mapper's eye images through
vtkStereoSpatioTemporalDenoiser, the denoised eyes' arrays and field data, and its
attachment to the mapper. Runs with Debian's /usr/bin/python3 (the one with vtkmodules)."""

import unittest

import holovolume
from vtkmodules.vtkCommonDataModel import vtkImageData, vtkPiecewiseFunction
from vtkmodules.vtkCommonMath import vtkMatrix4x4
from vtkmodules.vtkRenderingCore import (vtkCamera, vtkColorTransferFunction,
                                         vtkVolume, vtkVolumeProperty)


def ball_volume(scalar_at_radius, size=24):
    """A size^3 volume whose scalar depends on the distance r from its centre, in voxels."""
    image = vtkImageData()
    image.SetDimensions(size, size, size)
    image.AllocateScalars(3, 1)  # VTK_UNSIGNED_CHAR
    scalars = image.GetPointData().GetScalars()
    c = 0.5 * (size - 1)
    for k in range(size):
        for j in range(size):
            for i in range(size):
                r = ((i - c) ** 2 + (j - c) ** 2 + (k - c) ** 2) ** 0.5
                scalars.SetValue((k * size + j) * size + i, scalar_at_radius(r))
    return image


def sphere_volume(size=24):
    return ball_volume(lambda r: 200 if r < 0.35 * size else 0, size)


def graded_sphere_volume(size=24):
    """A ball whose scalar falls from 255 at its centre to 0 at its rim."""
    radius = 0.45 * size
    return ball_volume(lambda r: int(255 * max(0.0, 1.0 - r / radius)), size)


def eye_matrices(offset):
    camera = vtkCamera()
    camera.SetPosition(offset, 0, 60)
    camera.SetFocalPoint(offset, 0, 0)
    camera.SetViewAngle(30)
    camera.SetClippingRange(30, 90)
    view, projection = vtkMatrix4x4(), vtkMatrix4x4()
    view.DeepCopy(camera.GetModelViewTransformMatrix())
    projection.DeepCopy(camera.GetProjectionTransformMatrix(1.0, -1, 1))
    return view, projection


def sphere_scene():
    mapper = holovolume.vtkPathTracedVolumeMapper()
    mapper.SetInputData(sphere_volume())
    mapper.ProgressiveAccumulationOff()
    opacity = vtkPiecewiseFunction()
    opacity.AddPoint(0, 0.0)
    opacity.AddPoint(255, 0.5)
    color = vtkColorTransferFunction()
    color.AddRGBPoint(0, 0.9, 0.8, 0.7)
    color.AddRGBPoint(255, 0.9, 0.8, 0.7)
    prop = vtkVolumeProperty()
    prop.SetScalarOpacity(opacity)
    prop.SetColor(color)
    volume = vtkVolume()
    volume.SetMapper(mapper)
    volume.SetProperty(prop)
    return mapper, volume


def radiance_values(denoiser, eye):
    radiance = denoiser.GetEyeOutput(eye).GetPointData().GetArray("Radiance")
    return [radiance.GetValue(i) for i in range(radiance.GetNumberOfValues())]


class DenoiserPipelineTest(unittest.TestCase):
    def assert_same_first_frame_then_different(self, mapper, volume, denoisers):
        """Two stereo frames through two denoisers that differ in one history setting: on
        the first frame a history's mean is the frame's own value, so both give the same
        radiance; on the second they must differ."""
        left, right = eye_matrices(-1.0), eye_matrices(1.0)
        for frame in range(2):
            self.assertEqual(mapper.RenderStereoFrame(volume, left[0], left[1], right[0],
                                                      right[1], 40, 40), 1)
            for denoiser in denoisers:
                denoiser.SetLeftEyeData(mapper.GetEyeOutput(0))
                denoiser.SetRightEyeData(mapper.GetEyeOutput(1))
                denoiser.Update()
            for eye in (0, 1):
                first, second = (radiance_values(d, eye) for d in denoisers)
                if frame == 0:
                    self.assertEqual(first, second)
                else:
                    self.assertNotEqual(first, second)

    def test_package_exports_the_denoiser(self):
        self.assertIn("vtkStereoSpatioTemporalDenoiser", holovolume.__all__)

    def test_long_history_skips_the_last_wavelet_level(self):
        """WaveletLongHistory reaches the kernels: on a first frame (history 1), a threshold
        of 1 frame gives one wavelet level fewer, the default of 4 every level (D2 off, so
        that each pixel depends on its own eye only)."""
        mapper, volume = sphere_scene()
        left, right = eye_matrices(-1.0), eye_matrices(1.0)
        self.assertEqual(mapper.RenderStereoFrame(volume, left[0], left[1], right[0],
                                                  right[1], 40, 40), 1)
        denoisers = {}
        for name, levels, long_history in (("skips", 4, 1.0), ("fewer", 3, 0.0),
                                           ("default", 4, None), ("every", 4, 0.0)):
            denoiser = holovolume.vtkStereoSpatioTemporalDenoiser()
            denoiser.StereoBlendOff()
            denoiser.SetIlluminationDifference(0.0)
            denoiser.SetWaveletLevels(levels)
            if long_history is not None:
                denoiser.SetWaveletLongHistory(long_history)
            denoiser.SetLeftEyeData(mapper.GetEyeOutput(0))
            denoiser.SetRightEyeData(mapper.GetEyeOutput(1))
            denoiser.Update()
            denoisers[name] = denoiser
        self.assertEqual(denoisers["default"].GetWaveletLongHistory(), 4.0)
        denoisers["every"].SetWaveletLongHistory(-1.0)  # clamped: 0 is every level everywhere
        self.assertEqual(denoisers["every"].GetWaveletLongHistory(), 0.0)
        for eye in (0, 1):
            skips = radiance_values(denoisers["skips"], eye)
            self.assertEqual(skips, radiance_values(denoisers["fewer"], eye))
            every = radiance_values(denoisers["default"], eye)
            self.assertEqual(every, radiance_values(denoisers["every"], eye))
            self.assertNotEqual(skips, every)

    def test_wavelet_depth_from_history(self):
        """WaveletDepthFromHistory reaches the kernels: on a first frame a pixel's mean first
        scatter depth is the frame's own, and both settings give the same values; from the
        second frame on the translucent sphere's random depths and their mean differ, and so
        do the results."""
        mapper, volume = sphere_scene()
        self.assertTrue(holovolume.vtkStereoSpatioTemporalDenoiser()
                        .GetWaveletDepthFromHistory())
        denoisers = []
        for depth_from_history in (True, False):
            denoiser = holovolume.vtkStereoSpatioTemporalDenoiser()
            denoiser.SetIlluminationDifference(0.0)
            denoiser.SetWaveletDepthFromHistory(depth_from_history)
            denoisers.append(denoiser)
        self.assert_same_first_frame_then_different(mapper, volume, denoisers)

    def test_relight_from_previous_lighting(self):
        """The mapper's PreviousLightingRadiance reaches the kernels: a denoiser that relights
        by it and one that does not give the same first frame, and after the environment's
        intensity changed (T = 0.5) different ones; the one that does not use it gives what a
        denoiser fed the frames without the array gives."""
        mapper, volume = sphere_scene()
        mapper.SetRenderPreviousLighting(True)
        default = holovolume.vtkStereoSpatioTemporalDenoiser()
        self.assertTrue(default.GetRelightFromPreviousLighting())
        self.assertEqual(default.GetPreviousLightingRadius(), 4.0)
        self.assertEqual(default.GetPreviousLightingWeight(), 1.0)
        self.assertIn("PreviousLightingWeight: 1", str(default))
        denoisers = [holovolume.vtkStereoSpatioTemporalDenoiser() for _ in range(3)]
        denoisers[1].SetRelightFromPreviousLighting(False)
        left, right = eye_matrices(-1.0), eye_matrices(1.0)
        for frame, (intensity, t) in enumerate(((1.0, 0.0), (1.0, 0.0), (2.0, 0.5))):
            mapper.SetEnvironmentIntensity(intensity)
            self.assertEqual(mapper.RenderStereoFrame(volume, left[0], left[1], right[0],
                                                      right[1], 40, 40), 1)
            eyes = [mapper.GetEyeOutput(e) for e in (0, 1)]
            self.assertEqual(eyes[0].GetPointData().HasArray("PreviousLightingRadiance"),
                             1 if frame == 2 else 0)
            stripped = []
            for eye in eyes:
                copy = vtkImageData()
                copy.ShallowCopy(eye)
                copy.GetPointData().RemoveArray("PreviousLightingRadiance")
                stripped.append(copy)
            for k, denoiser in enumerate(denoisers):
                denoiser.SetIlluminationDifference(t)
                inputs = stripped if k == 2 else eyes
                denoiser.SetLeftEyeData(inputs[0])
                denoiser.SetRightEyeData(inputs[1])
                denoiser.Update()
            for eye in (0, 1):
                used, unused, without = (radiance_values(d, eye) for d in denoisers)
                self.assertEqual(unused, without)
                if frame < 2:
                    self.assertEqual(used, unused)
                else:
                    self.assertNotEqual(used, unused)

    def test_remodulate_by_history_albedo(self):
        """RemodulateByHistoryAlbedo and HistoryAlbedoGradients reach the kernels: on a first
        frame the mean albedo is the frame's, and re-modulation by either gives the same
        values; on the second, inside a sphere whose colour changes with its scalar, the
        random first scatter points' albedos and their mean differ, and so do the results."""
        mapper, volume = sphere_scene()
        mapper.SetInputData(graded_sphere_volume())
        color = volume.GetProperty().GetRGBTransferFunction()
        color.RemoveAllPoints()
        color.AddRGBPoint(0, 0.9, 0.2, 0.1)
        color.AddRGBPoint(255, 0.1, 0.3, 0.9)
        default = holovolume.vtkStereoSpatioTemporalDenoiser()
        self.assertTrue(default.GetRemodulateByHistoryAlbedo())
        self.assertEqual(default.GetHistoryAlbedoGradients(), (0.15, 0.3))
        denoisers = []
        for from_history in (True, False):
            denoiser = holovolume.vtkStereoSpatioTemporalDenoiser()
            denoiser.SetIlluminationDifference(0.0)
            denoiser.SetRemodulateByHistoryAlbedo(from_history)
            denoiser.SetHistoryAlbedoGradients(2.0, 2.0)  # the mean at every gradient
            denoisers.append(denoiser)
        self.assert_same_first_frame_then_different(mapper, volume, denoisers)

    def test_numpy_view_of_an_output_keeps_its_frame(self):
        """The filter denoises into the last frame's array only where no one else holds it:
        a NumPy view of an output (which holds the array) still shows its frame after the
        next one, and the next frame gets an array of its own."""
        from vtkmodules.util.numpy_support import vtk_to_numpy
        mapper, volume = sphere_scene()
        left, right = eye_matrices(-1.0), eye_matrices(1.0)
        denoiser = holovolume.vtkStereoSpatioTemporalDenoiser()
        views = []
        for _ in range(2):
            self.assertEqual(mapper.RenderStereoFrame(volume, left[0], left[1], right[0],
                                                      right[1], 40, 40), 1)
            denoiser.SetLeftEyeData(mapper.GetEyeOutput(0))
            denoiser.SetRightEyeData(mapper.GetEyeOutput(1))
            denoiser.Update()
            array = denoiser.GetEyeOutput(0).GetPointData().GetArray("Radiance")
            views.append((vtk_to_numpy(array), vtk_to_numpy(array).copy()))
        for view, copy in views:
            self.assertTrue((view == copy).all())
        # Two independent 2-spp frames: the second differs from the first.
        self.assertFalse((views[0][1] == views[1][1]).all())

    def test_mapper_eyes_through_the_denoiser(self):
        mapper, volume = sphere_scene()
        left, right = eye_matrices(-1.0), eye_matrices(1.0)

        denoiser = holovolume.vtkStereoSpatioTemporalDenoiser()
        denoiser.SetIlluminationDifference(0.0)
        denoiser.SetWaveletLevels(3)
        for _ in range(3):
            self.assertEqual(mapper.RenderStereoFrame(volume, left[0], left[1], right[0],
                                                      right[1], 40, 40), 1)
            denoiser.SetLeftEyeData(mapper.GetEyeOutput(0))
            denoiser.SetRightEyeData(mapper.GetEyeOutput(1))
            denoiser.Update()
        for eye in (0, 1):
            output = denoiser.GetEyeOutput(eye)
            self.assertEqual(output.GetDimensions(), (40, 40, 1))
            radiance = output.GetPointData().GetArray("Radiance")
            self.assertEqual(radiance.GetNumberOfComponents(), 4)
            self.assertIsNotNone(output.GetPointData().GetArray("Albedo"))
            fields = output.GetFieldData()
            # Three frames of a static view: the history grows, at most one frame a frame.
            history = fields.GetArray("MeanHistoryLength").GetValue(0)
            self.assertGreater(history, 1.5)
            self.assertLessEqual(history, 3.0)
            self.assertGreater(fields.GetArray("TemporalWeight").GetValue(0), 0.99)
            # The mapper's own image is untouched: its field data has no denoiser figures.
            self.assertIsNone(mapper.GetEyeOutput(eye).GetFieldData()
                              .GetArray("MeanHistoryLength"))
        self.assertGreater(denoiser.GetLastFrameMilliseconds(), 0.0)

        # A new frame for which T says the light changed. Relit (the default), the history is
        # kept; with relighting off (re-denoising the same frame), the paper's w_v drops it.
        self.assertEqual(denoiser.GetRelightingRadius(), 4.0)
        self.assertEqual(denoiser.GetRelitHistoryReuse(), 1.0)
        # Under a light that keeps changing the ratio's Gaussian is at least a sixtieth of the
        # image's height (clamped to [0, 0.1]), and the fine-scale test's variance takes the
        # history's; both reach the denoiser (PrintSelf).
        self.assertAlmostEqual(denoiser.GetRelightingRunHeightFraction(), 1.0 / 60.0)
        denoiser.SetRelightingRunHeightFraction(1.0)
        self.assertEqual(denoiser.GetRelightingRunHeightFraction(), 0.1)
        self.assertIn("RelightingRunHeightFraction: 0.1\n", str(denoiser))
        denoiser.SetRelightingRunHeightFraction(1.0 / 60.0)
        self.assertTrue(denoiser.GetRelitHistoryRejectionHistoryVariance())
        denoiser.RelitHistoryRejectionHistoryVarianceOff()
        self.assertIn("RelitHistoryRejectionHistoryVariance: Off", str(denoiser))
        denoiser.RelitHistoryRejectionHistoryVarianceOn()
        self.assertEqual(denoiser.GetRelightingRefinementFrames(), 4)
        self.assertEqual(denoiser.GetMaximumHistoryAngle(), 6.0)
        # The grazing view's narrower arc is on by default, below a cosine of 0.5; its settings
        # are clamped to [0, 1] and reach the denoiser (PrintSelf).
        self.assertEqual(denoiser.GetGrazingHistoryCosine(), 0.5)
        self.assertEqual(denoiser.GetGrazingHistoryFraction(), 0.5)
        denoiser.SetGrazingHistoryCosine(2.0)
        self.assertEqual(denoiser.GetGrazingHistoryCosine(), 1.0)
        denoiser.SetGrazingHistoryCosine(0.0)
        self.assertIn("GrazingHistoryCosine: 0\n", str(denoiser))
        self.assertIn("GrazingHistoryFraction: 0.5", str(denoiser))
        denoiser.SetGrazingHistoryCosine(0.5)
        self.assertFalse(denoiser.GetBicubicHistory())
        # A new transfer function drops the history unless asked to relight it (the issue's
        # behaviour by default).
        self.assertFalse(denoiser.GetRelightHistoryOnTransferFunctionChange())
        denoiser.RelightHistoryOnTransferFunctionChangeOn()
        self.assertTrue(denoiser.GetRelightHistoryOnTransferFunctionChange())
        denoiser.RelightHistoryOnTransferFunctionChangeOff()
        # ... and then keeps it only where the first scatter scalar stayed within 0.1.
        self.assertAlmostEqual(denoiser.GetClassificationScalarTolerance(), 0.1)
        denoiser.SetClassificationScalarTolerance(2.0)  # clamped to the data's whole range
        self.assertEqual(denoiser.GetClassificationScalarTolerance(), 1.0)
        denoiser.SetClassificationScalarTolerance(0.1)
        # ... and where the coverage it shows moved by more than 1.5 standard errors.
        self.assertAlmostEqual(denoiser.GetClassificationCoverageWidth(), 1.5)
        denoiser.SetClassificationCoverageWidth(-1.0)  # clamped: 0 switches the test off
        self.assertEqual(denoiser.GetClassificationCoverageWidth(), 0.0)
        denoiser.SetClassificationCoverageWidth(1.5)
        self.assertEqual(fields.GetArray("MaterialChangedFraction").GetValue(0), 0.0)
        self.assertIsNotNone(mapper.GetEyeOutput(0).GetPointData()
                             .GetArray("FirstScatterScalar"))
        # The wavelet filter and the history's weight compare normals only above a gradient
        # of 0.15 (translucent tissue's normals are noise below it).
        self.assertAlmostEqual(denoiser.GetWaveletNormalGradientFloor(), 0.15)
        self.assertAlmostEqual(denoiser.GetHistoryNormalGradientFloor(), 0.15)
        denoiser.SetWaveletNormalGradientFloor(2.0)  # clamped to the gradient's range
        self.assertEqual(denoiser.GetWaveletNormalGradientFloor(), 1.0)
        denoiser.SetHistoryNormalGradientFloor(-1.0)  # clamped: 0 counts the whole gradient
        self.assertEqual(denoiser.GetHistoryNormalGradientFloor(), 0.0)
        denoiser.SetWaveletNormalGradientFloor(0.15)
        denoiser.SetHistoryNormalGradientFloor(0.15)
        # ... and count the albedo in proportion to the larger gradient magnitude.
        self.assertEqual(denoiser.GetWaveletAlbedoGradientWeight(), 1.0)
        denoiser.SetWaveletAlbedoGradientWeight(1.5)  # clamped: 1 is the whole scaling
        self.assertEqual(denoiser.GetWaveletAlbedoGradientWeight(), 1.0)
        denoiser.SetWaveletAlbedoGradientWeight(-1.0)  # clamped: 0 counts the whole term
        self.assertEqual(denoiser.GetWaveletAlbedoGradientWeight(), 0.0)
        denoiser.SetWaveletAlbedoGradientWeight(1.0)
        self.assertEqual(denoiser.GetCoverageAgreementWidth(), 2.0)
        denoiser.SetCoverageAgreementWidth(-1.0)  # clamped: 0 filters coverage like colour
        self.assertEqual(denoiser.GetCoverageAgreementWidth(), 0.0)
        denoiser.SetCoverageAgreementWidth(2.0)
        self.assertEqual(denoiser.GetCrossViewCoverageWidth(), 1.0)
        denoiser.SetCrossViewCoverageWidth(-3.0)  # clamped: 0 takes the other eye as it is
        self.assertEqual(denoiser.GetCrossViewCoverageWidth(), 0.0)
        denoiser.SetCrossViewCoverageWidth(1.0)
        self.assertEqual(denoiser.GetSurfaceJitterTolerance(), 3.0)
        self.assertAlmostEqual(denoiser.GetNormalTestGradient(), 0.3)
        denoiser.SetNormalTestGradient(2.0)  # clamped to a gradient magnitude
        self.assertEqual(denoiser.GetNormalTestGradient(), 1.0)
        denoiser.SetNormalTestGradient(0.3)
        self.assertEqual(denoiser.GetStereoAgreementWidth(), 8.0)  # beyond the paper; 0 is its D2
        denoiser.SetStereoAgreementWidth(-1.0)  # clamped: 0 switches the test off
        self.assertEqual(denoiser.GetStereoAgreementWidth(), 0.0)
        self.assertEqual(mapper.RenderStereoFrame(volume, left[0], left[1], right[0],
                                                  right[1], 40, 40), 1)
        denoiser.SetIlluminationDifference(0.5)
        denoiser.Update()
        fields = denoiser.GetEyeOutput(0).GetFieldData()
        self.assertLess(fields.GetArray("TemporalWeight").GetValue(0), 0.01)
        self.assertGreater(fields.GetArray("MeanHistoryLength").GetValue(0), 1.5)
        denoiser.SetRelightingRadius(0.0)
        denoiser.Update()
        fields = denoiser.GetEyeOutput(0).GetFieldData()
        self.assertLess(fields.GetArray("MeanHistoryLength").GetValue(0), 1.1)

        mapper.SetDenoiser(denoiser)
        self.assertIs(mapper.GetDenoiser(), denoiser)
        mapper.SetDenoiser(None)


if __name__ == "__main__":
    unittest.main()
