"""Checks where holovolume's live mode puts a lamp for a camera mounted on the headset.

    check_camera_mount.py SIMULATOR HOLOVOLUME VOLUME WORK_DIR

Films one frame of a room with a small lamp at a known direction in the camera's frame
(SIMULATOR is holovolume-simulate-camera), then runs HOLOVOLUME in live mode on VOLUME with the
headset at the volume's centre and several --camera-mount values, and finds the lamp in the
radiance map it used (live-environment.vti, in the room frame: +Y up, the headset facing -Z).

The expected direction is worked out here, independently of the application's code, from what
--help promises: the camera sits at the offset (x right, y up, z back) from the headset, its
front lens turned by yaw (to the left), then pitch (up), then roll (counter-clockwise as the
wearer sees it); the lamp lies on the proxy sphere of radius R around the camera, and the map
shows it as seen from the volume's centre. The lamp's centroid must lie within 1.5 degrees of
that direction (a texel of the 512-wide map is 0.7 degrees; measured 0.08-0.18). Flipping the
sign of any one number of the last mount moves the expected lamp by 6 to 34 degrees, and of the
others (but the yaw of 180, its own mirror) by 37 to 100, so a convention the application gets
wrong fails the test.
"""
import math
import os
import subprocess
import sys

import numpy as np
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkIOXML import vtkXMLImageDataReader

LAMP_AZIMUTH, LAMP_ELEVATION = 90.0, 40.0  # degrees, in the camera's frame
PROXY_RADIUS = 2500.0
TOLERANCE_DEGREES = 1.5

# --camera-mount values: at the eyes, turned, moved back, and everything at once.
MOUNTS = ["0,0,0", "0,0,0,90", "0,0,0,180", "0,0,0,0,30", "0,0,1000", "300,-200,800,-30,15,10"]


def rotation(axis, degrees):
    """Right-handed rotation about a coordinate axis (0 x, 1 y, 2 z)."""
    c, s = math.cos(math.radians(degrees)), math.sin(math.radians(degrees))
    i, j = [(1, 2), (2, 0), (0, 1)][axis]
    m = np.eye(3)
    m[i, i], m[i, j], m[j, i], m[j, j] = c, -s, s, c
    return m


def direction(azimuth, elevation):
    """The map's convention: azimuth from -Z towards +X, elevation above the horizon."""
    a, e = math.radians(azimuth), math.radians(elevation)
    return np.array([math.cos(e) * math.sin(a), math.sin(e), -math.cos(e) * math.cos(a)])


def expected_lamp(mount):
    values = [float(v) for v in mount.split(",")] + [0.0] * 3
    offset, (yaw, pitch, roll) = np.array(values[:3]), values[3:6]
    turn = rotation(1, yaw) @ rotation(0, pitch) @ rotation(2, roll)
    seen = turn @ direction(LAMP_AZIMUTH, LAMP_ELEVATION)
    point = offset + PROXY_RADIUS * seen  # the lamp on the sphere around the camera
    return point / np.linalg.norm(point)


def measured_lamp(path):
    reader = vtkXMLImageDataReader()
    reader.SetFileName(path)
    reader.Update()
    image = reader.GetOutput()
    width, height, _ = image.GetDimensions()
    radiance = vtk_to_numpy(image.GetPointData().GetScalars()).reshape(height, width, -1)[..., :3]
    luminance = radiance @ np.array([0.2126, 0.7152, 0.0722])
    rows, columns = np.nonzero(luminance > 0.5 * luminance.max())
    weights = luminance[rows, columns]
    # VTK's row 0 is the bottom of the panorama (the nadir); u from the left edge.
    u = (columns + 0.5) / width
    theta = math.pi * (1.0 - (rows + 0.5) / height)
    phi = (u - 0.5) * 2.0 * math.pi
    vectors = np.stack(
        [np.sin(theta) * np.sin(phi), np.cos(theta), -np.sin(theta) * np.cos(phi)], axis=1)
    mean = (vectors * weights[:, None]).sum(axis=0)
    return mean / np.linalg.norm(mean)


def angles(d):
    return math.degrees(math.atan2(d[0], -d[2])), math.degrees(math.asin(max(-1.0, min(1.0, d[1]))))


def main():
    simulator, holovolume, volume, work = sys.argv[1:5]
    os.makedirs(work, exist_ok=True)
    frames = os.path.join(work, "lamp_%d.png")
    subprocess.run([simulator, "--frames", "1", "--frame-size", "480x240",
                    "--light-switch-frame", "0", "--lamp-radius", "6",
                    "--lamp-direction", f"{LAMP_AZIMUTH:g},{LAMP_ELEVATION:g}",
                    "--output", frames], check=True, capture_output=True)
    errors = []
    for mount in MOUNTS:
        output = os.path.join(work, "mount-" + mount.replace(",", "_"))
        run = subprocess.run(
            [holovolume, "--camera", frames, "--volume", volume, "--width", "24", "--height", "16",
             "--camera-frames", "1", "--headset-position", "center",
             "--proxy-radius", f"{PROXY_RADIUS:g}", "--camera-mount", mount,
             "--save-buffers", "--output", output], capture_output=True, text=True)
        if run.returncode != 0:
            errors.append(f"--camera-mount {mount}: holovolume exited with {run.returncode}: "
                          f"{run.stderr.strip()}")
            continue
        expected = expected_lamp(mount)
        measured = measured_lamp(os.path.join(output, "live-environment.vti"))
        off = math.degrees(math.acos(max(-1.0, min(1.0, float(expected @ measured)))))
        print(f"--camera-mount {mount:24s} lamp expected at azimuth {angles(expected)[0]:7.2f}, "
              f"elevation {angles(expected)[1]:6.2f}; found at {angles(measured)[0]:7.2f}, "
              f"{angles(measured)[1]:6.2f}: {off:.2f} degrees off")
        if not off <= TOLERANCE_DEGREES:
            errors.append(f"--camera-mount {mount}: the lamp is {off:.2f} degrees from where the "
                          f"mount puts it (tolerance {TOLERANCE_DEGREES})")
    return "\n".join(errors) or None


if __name__ == "__main__":
    sys.exit(main())
