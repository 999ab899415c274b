"""holovolume-denoise-evaluation --reference-cache: the tables are the same, byte for byte, whether
the references are rendered or read from the cache; a run that tunes only the denoiser reads every
reference; a damaged entry is rendered again; an option that changes the references reads none;
the partial files of runs killed while writing are removed once their writers are gone.

    check_reference_cache.py EVALUATION WORKDIR [OPTION...]

The options (e.g. --volume and --environment) go to every run.
"""

import os
import pathlib
import re
import shutil
import subprocess
import sys

from checklist import Checklist

evaluation, workdir = sys.argv[1], pathlib.Path(sys.argv[2])
shutil.rmtree(workdir, ignore_errors=True)
workdir.mkdir(parents=True)
cache = workdir / "cache"
# Tiny, so that the test takes seconds: the static view and its raw-spp curve, 4 orbit frames
# and the light switch's two references (before and after the lamp).
arguments = ["--size", "40x26", "--frames", "4", "--reference-spp", "64",
             "--sequences", "static,orbit,switch", "--switch-runs", "1", *sys.argv[3:]]
entries = 1 + 1 + 4 + 2
checks = Checklist()
expect = checks.expect


def run(name, *extra):
    """The evaluation's tables and its cache line (read, rendered) of one run."""
    result = subprocess.run([evaluation, *arguments, *extra], capture_output=True, text=True)
    if result.returncode != 0:
        sys.exit(f"{name}: exit status {result.returncode}\n{result.stderr}")
    (workdir / f"{name}.md").write_text(result.stdout)
    counts = re.search(r"reference cache .*: (\d+) read, (\d+) rendered and kept", result.stderr)
    return result.stdout, result.stderr, (
        (int(counts.group(1)), int(counts.group(2))) if counts else None)


plain, _, counts = run("plain")
expect("without --reference-cache no cache line", counts is None)

cold, _, counts = run("cold", "--reference-cache", str(cache))
expect(f"first run with the cache renders and keeps all {entries} entries: {counts}",
       counts == (0, entries))
expect("its tables are those of the run without the cache", cold == plain)

# The partial files of a run killed while it wrote an entry: one whose writer has exited, one
# whose writer (this script) still runs.
finished = subprocess.Popen(["true"])
finished.wait()
some_entry = sorted(cache.glob("*.reference"))[0]
stale = cache / f"{some_entry.name}.part.{finished.pid}"
live = cache / f"{some_entry.name}.part.{os.getpid()}"
stale.write_bytes(b"cut short")
live.write_bytes(b"being written")
# A file of another program that only looks like one (the directory may be shared).
foreign = cache / f"download.part.{finished.pid}"
foreign.write_bytes(b"not the cache's")

warm, stderr, counts = run("warm", "--reference-cache", str(cache))
expect(f"second run reads all {entries}: {counts}", counts == (entries, 0))
expect("its tables are the same byte for byte", warm == plain)
expect("it removes the partial file of a run that has ended", not stale.exists())
expect("and says so", "removed 1 partial entry left by runs stopped while writing" in stderr)
expect("it keeps the partial file of a process that still runs", live.exists())
expect("and a file of another name format", foreign.exists())
live.unlink()
foreign.unlink()

# A file cut short (a killed run, a full disk) is found by its checksum and rendered again.
damaged = sorted(cache.glob("*.reference"))[0]
damaged.write_bytes(damaged.read_bytes()[:1000])
repaired, stderr, counts = run("repaired", "--reference-cache", str(cache))
expect("a damaged entry is reported", "is cut short or damaged" in stderr)
expect(f"and rendered again, the others read: {counts}", counts == (entries - 1, 1))
expect("the tables are the same", repaired == plain)

# A denoiser option leaves the references as they are...
tuned_plain, _, _ = run("tuned-plain", "--stereo-agreement-width", "3")
tuned, _, counts = run("tuned", "--stereo-agreement-width", "3", "--reference-cache", str(cache))
expect(f"a denoiser option reads every reference: {counts}", counts == (entries, 0))
expect("and gives the tables of that option without the cache", tuned == tuned_plain)
expect("which differ from the defaults' (the option was applied)", tuned != plain)

# ...a renderer option does not.
_, _, counts = run("random-subpixels", "--subpixel-samples", "random",
                   "--reference-cache", str(cache))
expect(f"random subpixel samples render every reference: {counts}", counts == (0, entries))

checks.finish("reference cache: all checks passed")
