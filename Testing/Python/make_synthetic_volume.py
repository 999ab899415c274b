"""Writes a small synthetic volume (VTK XML image) for the application's smoke tests."""

import sys

from vtkmodules.vtkImagingCore import vtkRTAnalyticSource
from vtkmodules.vtkImagingCore import vtkImageShiftScale
from vtkmodules.vtkIOXML import vtkXMLImageDataWriter

source = vtkRTAnalyticSource()
source.SetWholeExtent(-20, 20, -20, 20, -20, 20)
# Map the blob's scalars (~37..277) to 0..255 like an 8-bit MRI.
scale = vtkImageShiftScale()
scale.SetInputConnection(source.GetOutputPort())
scale.SetShift(-37.0)
scale.SetScale(255.0 / 240.0)
scale.SetOutputScalarTypeToUnsignedChar()
scale.ClampOverflowOn()
writer = vtkXMLImageDataWriter()
writer.SetInputConnection(scale.GetOutputPort())
writer.SetFileName(sys.argv[1])
if writer.Write() != 1:
    sys.exit(1)
