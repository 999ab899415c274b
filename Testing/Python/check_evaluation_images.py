"""holovolume-denoise-evaluation --images: the thumbnail strip and the noise discrepancy map.

    check_evaluation_images.py EVALUATION WORKDIR [OPTION...]

Runs a short still view at 40x26 with the options given (e.g. --volume, --environment) and
checks the strip (the five methods and the reference side by side) and the map: D1's and the full denoiser's
per-pixel noise discrepancy on one colour scale, beside the reference. The two maps must mark
the same pixels as paired, and the full denoiser's must be darker there on the mean: D2 averages
the eyes' noise, which the inferno colour map shows as lower luminance.

Then Utilities/Scripts/denoise-figures.py, which makes Denoising.md's pictures from these files,
on them: its shrink must average each block, its close-up must show the strip's panels at
the frame's own pixels, and its error table must put the reference at 0 and the full denoiser
below the raw frame.
"""

import pathlib
import shutil
import subprocess
import sys

from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkIOImage import vtkPNGReader

from checklist import Checklist

evaluation, workdir = sys.argv[1], pathlib.Path(sys.argv[2])
shutil.rmtree(workdir, ignore_errors=True)
workdir.mkdir(parents=True)
width, height = 40, 26
result = subprocess.run([evaluation, "--size", f"{width}x{height}", "--frames", "6",
                         "--reference-spp", "64", "--sequences", "static",
                         "--images", str(workdir), *sys.argv[3:]],
                        capture_output=True, text=True)
if result.returncode != 0:
    sys.exit(f"evaluation failed ({result.returncode}):\n{result.stderr}")
checks = Checklist()
expect = checks.expect


def read_png(path):
    """The image as rows from the top, RGB; VTK's reader puts the bottom row first."""
    reader = vtkPNGReader()
    reader.SetFileName(str(path))
    reader.Update()
    image = reader.GetOutput()
    columns, rows, _ = image.GetDimensions()
    pixels = vtk_to_numpy(image.GetPointData().GetScalars())
    return pixels.reshape(rows, columns, -1)[::-1, :, :3].astype(float)


strip_path = workdir / "denoise-static.png"
map_path = workdir / "denoise-static-discrepancy.png"
expect(f"{strip_path.name} and {map_path.name} written", strip_path.exists() and map_path.exists())
if checks.failures:
    sys.exit("the pictures are missing")

strip = read_png(strip_path)
# Six panels (raw, spatial only, temporal only, D1, D1 + D2, the reference), magnified twice.
expect(f"the strip is 6 panels of {width}x{height}, twice magnified: {strip.shape[:2]}",
       strip.shape[:2] == (2 * height, 2 * 6 * width))

figure = read_png(map_path)
# D1's map, a 4-pixel separator, the full denoiser's, a separator, the reference; twice magnified.
expect(f"the map is three {width}x{height} panels wide, twice magnified: {figure.shape[1]}",
       figure.shape[1] == 2 * (3 * width + 8))
maps = [figure[:2 * height, 2 * offset:2 * (offset + width)] for offset in (0, width + 4)]
reference = figure[:2 * height, 2 * (2 * width + 8):]
unpaired_grey = 48.0
paired = [(panel != unpaired_grey).any(axis=2) for panel in maps]
expect(f"some pixels are paired: {int(paired[0].sum())} of {paired[0].size}",
       paired[0].sum() > 0)
expect("both maps mark the same pixels as paired", (paired[0] == paired[1]).all())
luminance = [(panel @ [0.2126, 0.7152, 0.0722])[paired[0]].mean() for panel in maps]
expect(f"the full denoiser's map is darker than D1's: {luminance[1]:.1f} < {luminance[0]:.1f}",
       luminance[1] < luminance[0])
expect("the reference shows the volume", reference.max() > 0)

figures = pathlib.Path(__file__).resolve().parents[2] / "Utilities" / "Scripts" / "denoise-figures.py"


def run_figures(*arguments):
    run = subprocess.run([sys.executable, str(figures), *arguments], capture_output=True, text=True)
    expect(f"denoise-figures.py {arguments[0]} ran: {run.stderr.strip()}", run.returncode == 0)
    return run.stdout


# A factor of 4: the map is magnified twice, so 2x2 blocks would be uniform and a shrink that
# only subsampled would pass.
run_figures("shrink", str(map_path), str(workdir / "map-shrunk.png"), "--factor", "4")
shrunk = read_png(workdir / "map-shrunk.png")
rows, columns = figure.shape[0] // 4, figure.shape[1] // 4
blocks = figure[:4 * rows, :4 * columns].reshape(rows, 4, columns, 4, 3).mean(axis=(1, 3))
expect(f"the shrunk map is {columns}x{rows}: {shrunk.shape[1]}x{shrunk.shape[0]}",
       shrunk.shape[:2] == (rows, columns))
if shrunk.shape[:2] == (rows, columns):
    expect("each of its pixels is its 4x4 block's mean, rounded",
           abs(shrunk - blocks).max() <= 0.5)

table = run_figures("closeup", str(strip_path), str(workdir / "closeup.png"),
                    "--box", "0", "0", str(width), str(height), "--panels", "4,5")
closeup = read_png(workdir / "closeup.png")
expect(f"the close-up is two {width}x{height} panels and a separator: {closeup.shape[:2]}",
       closeup.shape[:2] == (height, 2 * width + 4))
if closeup.shape[:2] == (height, 2 * width + 4):
    own_pixels = strip[::2, ::2]
    expect("its panels are the full denoiser's and the reference's at the frame's own pixels",
           (closeup[:, :width] == own_pixels[:, 4 * width:5 * width]).all()
           and (closeup[:, width + 4:] == own_pixels[:, 5 * width:]).all())
expect(f"it counts the dark spots of four panels:\n{table}",
       all(f"| {name} |" in table for name in ("spatial only", "D1", "full", "reference")))

errors_table = run_figures("errors", str(strip_path))
rows = {line.split("|")[1].strip(): [float(v) for v in line.split("|")[2:5]]
        for line in errors_table.splitlines()
        if line.startswith("| ") and not line.startswith("| panel")}
expect(f"its error table has a row for each panel:\n{errors_table}",
       set(rows) == {"raw 2 spp", "spatial only", "temporal only", "D1", "full", "reference"})
if "reference" in rows and "full" in rows:
    expect("the reference's error is 0", rows["reference"][:2] == [0.0, 0.0])
    expect("the full denoiser's error is below raw 2 spp's",
           0 < rows["full"][0] < rows["raw 2 spp"][0])
    expect("smoothing keeps less of the raw frame's error than there is (its noise is per pixel)",
           rows["raw 2 spp"][1] < rows["raw 2 spp"][0])

# The map is not a strip: the script says so instead of failing on it.
wrong = subprocess.run([sys.executable, str(figures), "errors", str(map_path)],
                       capture_output=True, text=True)
expect(f"errors on the map is refused with a message: {wrong.stderr.strip()}",
       wrong.returncode != 0 and "is not a strip of 6 panels" in wrong.stderr)

checks.finish("evaluation images: all checks passed")
