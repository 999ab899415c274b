"""vtkHoloLensRemotingOutput from Python: it starts on a free loopback port, prints a URL
with its token, serves the player page only with that token (403 without), and refuses a
network address unless remote connections are allowed. Runs with Debian's /usr/bin/python3."""

import unittest
import urllib.error
import urllib.request

import holovolume
from vtkmodules.vtkCommonDataModel import vtkImageData
from vtkmodules.vtkRenderingCore import vtkVolume


def cube_volume(size=16):
    image = vtkImageData()
    image.SetDimensions(size, size, size)
    image.AllocateScalars(3, 1)  # VTK_UNSIGNED_CHAR
    image.GetPointData().GetScalars().Fill(200)
    return image


class RemotingOutputTest(unittest.TestCase):
    def setUp(self):
        mapper = holovolume.vtkPathTracedVolumeMapper()
        mapper.SetInputData(cube_volume())
        self.volume = vtkVolume()
        self.volume.SetMapper(mapper)
        self.output = holovolume.vtkHoloLensRemotingOutput()
        self.output.SetVolume(self.volume)
        self.output.SetPort(0)
        self.output.SetLogConnections(False)

    def tearDown(self):
        self.output.Stop()

    def test_serves_the_player_with_the_token_only(self):
        self.assertEqual(self.output.Start(), 1)
        port = self.output.GetBoundPort()
        token = self.output.GetAccessToken()
        self.assertGreater(port, 0)
        self.assertEqual(len(token), 32)
        self.assertEqual(self.output.GetUrl(), f"http://127.0.0.1:{port}/?token={token}")
        with urllib.request.urlopen(self.output.GetUrl(), timeout=10) as response:
            self.assertEqual(response.status, 200)
            page = response.read().decode()
            self.assertIn("<html", page.lower())
            self.assertIn("holovolume_token=", response.headers["Set-Cookie"])
        with self.assertRaises(urllib.error.HTTPError) as refused:
            urllib.request.urlopen(f"http://127.0.0.1:{port}/", timeout=10)
        self.assertEqual(refused.exception.code, 403)
        # No client: the render loop waits instead of rendering.
        self.assertEqual(self.output.ProcessFrame(0.01), 0)

    def test_network_address_needs_permission(self):
        self.output.SetBindAddress("0.0.0.0")
        self.output.GlobalWarningDisplayOff()
        self.assertEqual(self.output.Start(), 0)
        self.output.SetAllowRemoteConnections(True)
        self.assertEqual(self.output.Start(), 1)


if __name__ == "__main__":
    unittest.main()
