"""holovolume-denoise-evaluation's "error's frame-to-frame change": the mean absolute change of
(display - reference) from one frame to the next, which leaves out what the scene itself does.

    check_error_change.py EVALUATION [OPTION...]

The options (e.g. --volume and --environment) go to the run. In the still view the reference is
one image for every frame, so the error's change must equal the flicker figure (the display's own
change, minus the references' change of 0) for every method; and a method that keeps a history
must move its error less than the raw frames, whose noise is new every frame, in the still view
and under the orbit alike.
"""

import re
import subprocess
import sys

from checklist import Checklist

evaluation = sys.argv[1]
arguments = ["--size", "40x26", "--frames", "8", "--reference-spp", "64",
             "--sequences", "static,orbit", *sys.argv[2:]]
result = subprocess.run([evaluation, *arguments], capture_output=True, text=True)
if result.returncode != 0:
    sys.exit(f"exit status {result.returncode}\n{result.stderr}")
checks = Checklist()
expect = checks.expect


def cells(line):
    return [cell.strip() for cell in line.strip("|").split("|")]


def main_table(sequence):
    """The sequence's first table, as {method: {column: text}}, and the references' flicker."""
    section = result.stdout.split(f"## Sequence: {sequence}\n", 1)[1]
    lines = [line for line in section.split("\n\n", 2)[1].splitlines() if line.startswith("|")]
    header = cells(lines[0])
    rows = {row[0]: dict(zip(header, row)) for row in map(cells, lines[2:])}
    reference = float(re.search(r"minus the references' \(([-0-9.]+)\)", section).group(1))
    return rows, reference


change = "error's frame-to-frame change (x1000)"
for sequence in ("static", "orbit"):
    rows, reference_flicker = main_table(sequence)
    expect(f"{sequence}: the table has the column '{change}'",
           all(change in row for row in rows.values()))
    raw = float(rows["raw 2 spp"][change])
    for method in ("temporal only", "D1", "D1 + D2 (full)"):
        value = float(rows[method][change])
        expect(f"{sequence}: {method} moves its error less than raw 2 spp ({value} < {raw})",
               0.0 < value < raw)
    if sequence == "static":
        expect(f"static: the references do not change ({reference_flicker})",
               reference_flicker == 0.0)
        for method, row in rows.items():
            flicker = float(row["flicker (x1000)"])
            expect(f"static: {method}'s error change {row[change]} equals its flicker {flicker}",
                   abs(float(row[change]) - flicker) <= 0.011)

checks.finish("error change: all checks passed")
