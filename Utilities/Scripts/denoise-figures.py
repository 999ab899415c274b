#!/usr/bin/python3
"""Documentation figures from holovolume-denoise-evaluation's --images output.

  shrink IN OUT [--factor N]
      IN reduced N times per axis by averaging each N x N block (the maps in
      Documentation/Denoising.md at a quarter of their size).
  closeup STRIP OUT [--box X0 Y0 X1 Y1] [--panels LIST]
      the strip's panels (raw, spatial only, temporal only, D1, full, reference) at the frame's
      own pixels (the strip doubles each pixel), cropped to the box and set side by side; it
      prints, for the spatial filter, D1, the full denoiser and the reference, how many pixels
      are dark spots (more than 20 % below the median of their 5x5 neighbourhood), in the box and
      over the head away from its edge (where the reference, eroded by a disc of 7 pixels, is
      above 30 of 255).
  errors STRIP [--sigma S]
      for each panel, over the same part of the head: the RMS of its error against the
      reference (display levels of 255, the mean of the three channels), the RMS of that error
      smoothed by a Gaussian of S pixels [3] (vtkImageGaussianSmooth), which keeps the blotches
      a few pixels and more across and drops the pixel-scale noise, and its dark spots.

Run with /usr/bin/python3 (Debian's VTK) on the PNGs the evaluation wrote.
"""

import argparse
import sys

import numpy as np
import vtk
from vtk.util.numpy_support import numpy_to_vtk, vtk_to_numpy

PANEL_NAMES = ["raw 2 spp", "spatial only", "temporal only", "D1", "full", "reference"]
SPOT_PANELS = [1, 3, 4, 5]


def read_png(path):
    reader = vtk.vtkPNGReader()
    if not reader.CanReadFile(path):
        sys.exit(f"denoise-figures: cannot read {path} as PNG; pass a file that "
                 "holovolume-denoise-evaluation --images wrote")
    reader.SetFileName(path)
    reader.Update()
    return reader.GetOutput()


def write_png(image, path):
    writer = vtk.vtkPNGWriter()
    writer.SetCompressionLevel(9)
    writer.SetFileName(path)
    writer.SetInputData(image)
    writer.Write()


def to_array(image):
    """Rows top-down, as the PNG shows them (VTK keeps the bottom row first)."""
    width, height, _ = image.GetDimensions()
    scalars = vtk_to_numpy(image.GetPointData().GetScalars())
    return scalars.reshape(height, width, -1)[::-1]


def to_image(array):
    image = vtk.vtkImageData()
    image.SetDimensions(array.shape[1], array.shape[0], 1)
    flat = np.ascontiguousarray(array[::-1]).reshape(array.shape[0] * array.shape[1], -1)
    image.GetPointData().SetScalars(numpy_to_vtk(flat, deep=1))
    return image


def filtered(array, image_filter, kernel):
    """A plane through a VTK image filter of a kernel x kernel footprint (truncated at the
    image's border)."""
    image_filter.SetKernelSize(kernel, kernel, 1)
    image_filter.SetInputData(to_image(array.astype(np.float32)))
    image_filter.Update()
    return to_array(image_filter.GetOutput())[:, :, 0]


def shrink(args):
    # vtkImageShrink3D averages in the input's scalar type, which would truncate 8-bit means;
    # cast to float first and round once at the end.
    cast = vtk.vtkImageCast()
    cast.SetInputData(read_png(args.input))
    cast.SetOutputScalarTypeToFloat()
    shrinker = vtk.vtkImageShrink3D()
    shrinker.SetInputConnection(cast.GetOutputPort())
    shrinker.SetShrinkFactors(args.factor, args.factor, 1)
    shrinker.AveragingOn()
    shrinker.Update()
    averaged = to_array(shrinker.GetOutput())
    write_png(to_image(np.clip(np.rint(averaged), 0, 255).astype(np.uint8)), args.output)
    print(f"{args.output}: {averaged.shape[1]}x{averaged.shape[0]}")


def strip_panels(path):
    """The strip's panels at the frame's own pixels (the strip doubles each pixel)."""
    strip = to_array(read_png(path))
    if strip.shape[1] % len(PANEL_NAMES) != 0:
        sys.exit(f"denoise-figures: {path} is not a strip of {len(PANEL_NAMES)} panels "
                 "(use denoise-SEQUENCE.png, not the discrepancy map)")
    doubled = strip[0::2, 0::2]
    if not np.array_equal(doubled, strip[1::2, 1::2]):
        sys.exit(f"denoise-figures: {path} does not double each pixel; was it resized?")
    width = doubled.shape[1] // len(PANEL_NAMES)
    return [doubled[:, i * width:(i + 1) * width] for i in range(len(PANEL_NAMES))]


def panel_luminances(panels):
    return [panel[:, :, :3].astype(np.float32).mean(axis=2) for panel in panels]


def head_mask(luminance):
    """The head away from its edge: the reference, eroded by a disc of 7 pixels, above 30."""
    return filtered(luminance[5], vtk.vtkImageContinuousErode3D(), 7) > 30


def dark_spots(luminance):
    """Pixels more than 20 % below the median of their 5x5 neighbourhood."""
    return luminance < 0.8 * filtered(luminance, vtk.vtkImageMedian3D(), 5)


def closeup(args):
    panels = strip_panels(args.input)
    height, width = panels[0].shape[:2]
    x0, y0, x1, y1 = args.box
    if not (0 <= x0 < x1 <= width and 0 <= y0 < y1 <= height):
        sys.exit(f"denoise-figures: the box must lie within {width}x{height}")

    separator = np.full((y1 - y0, 4, 3), 255, np.uint8)
    parts = []
    for index in args.panels:
        parts += [panels[index][y0:y1, x0:x1, :3], separator]
    write_png(to_image(np.concatenate(parts[:-1], axis=1)), args.output)

    luminance = panel_luminances(panels)
    head = head_mask(luminance)
    print(f"{args.output}: box {x0},{y0} to {x1},{y1}; the head away from its edge: "
          f"{int(head.sum())} pixels")
    print("| panel | dark spots in the box | over the head |")
    print("|---|---:|---:|")
    for index in SPOT_PANELS:
        spots = dark_spots(luminance[index]) & head
        print(f"| {PANEL_NAMES[index]} | {int(spots[y0:y1, x0:x1].sum())} | {int(spots.sum())} |")


def errors(args):
    panels = strip_panels(args.input)
    luminance = panel_luminances(panels)
    head = head_mask(luminance)
    reference = panels[5][:, :, :3].astype(np.float32)
    print(f"{args.input}: the head away from its edge, {int(head.sum())} pixels; display levels "
          f"of 255")
    print(f"| panel | RMS error | smoothed by a Gaussian of {args.sigma:g} px | dark spots |")
    print("|---|---:|---:|---:|")
    for index, panel in enumerate(panels):
        error = (panel[:, :, :3].astype(np.float32) - reference).mean(axis=2)
        smoothing = vtk.vtkImageGaussianSmooth()
        smoothing.SetDimensionality(2)
        smoothing.SetStandardDeviations(args.sigma, args.sigma, 0.0)
        smoothing.SetRadiusFactors(3.0, 3.0, 0.0)
        smoothing.SetInputData(to_image(error[:, :, np.newaxis]))
        smoothing.Update()
        smoothed = to_array(smoothing.GetOutput())[:, :, 0]
        spots = dark_spots(luminance[index]) & head
        print(f"| {PANEL_NAMES[index]} | {np.sqrt(np.mean(error[head] ** 2)):.2f} | "
              f"{np.sqrt(np.mean(smoothed[head] ** 2)):.2f} | {int(spots.sum())} |")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0],
                                     formatter_class=argparse.RawDescriptionHelpFormatter,
                                     epilog=__doc__.split("\n", 2)[2])
    commands = parser.add_subparsers(dest="command", required=True)
    shrink_parser = commands.add_parser("shrink", help="average N x N blocks")
    shrink_parser.add_argument("input")
    shrink_parser.add_argument("output")
    shrink_parser.add_argument("--factor", type=int, default=4)
    closeup_parser = commands.add_parser("closeup", help="crop panels at the frame's own pixels")
    closeup_parser.add_argument("input")
    closeup_parser.add_argument("output")
    closeup_parser.add_argument("--box", type=int, nargs=4, default=[640, 480, 1020, 800],
                                metavar=("X0", "Y0", "X1", "Y1"),
                                help="in the frame's pixels, from its top left "
                                     "[the brow and an eye socket at 1440x936]")
    closeup_parser.add_argument("--panels", type=lambda s: [int(v) for v in s.split(",")],
                                default=[0, 4, 5],
                                help="0 raw, 1 spatial, 2 temporal, 3 D1, 4 full, 5 reference "
                                     "[0,4,5]")
    errors_parser = commands.add_parser("errors", help="each panel's error over the head")
    errors_parser.add_argument("input")
    errors_parser.add_argument("--sigma", type=float, default=3.0,
                               help="the Gaussian's standard deviation in pixels [3]")
    args = parser.parse_args()
    if args.command == "errors":
        if not args.sigma > 0:
            parser.error("--sigma must be more than 0")
        errors(args)
    elif args.command == "shrink":
        if args.factor < 1:
            parser.error("--factor must be 1 or more")
        shrink(args)
    else:
        if any(not 0 <= index < len(PANEL_NAMES) for index in args.panels):
            parser.error(f"--panels takes indices from 0 to {len(PANEL_NAMES) - 1}")
        closeup(args)


if __name__ == "__main__":
    main()
