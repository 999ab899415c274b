# SPDX-License-Identifier: BSD-3-Clause
# Copyright (c) 2026 the HoloVolume developers.
"""Serve one video file over HTTP as a live stream, for PanoramaFrameGrabber's tests.

A camera that streams over HTTP never ends and sends its bytes at the rate they are
recorded; this server imitates that by sending the file at --rate bytes per second and,
with --loop, starting it over at its end (MPEG-TS may be concatenated: every packet is
self-contained). It listens on 127.0.0.1 only, prints "PORT <n>" once it accepts
connections (--port 0 picks a free port) and serves until it is terminated.
"""
import argparse
import http.server
import os
import socketserver
import sys
import time


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("file", help="the video file to stream")
    parser.add_argument("--port", type=int, default=0)
    parser.add_argument("--rate", type=float, default=0.0,
                        help="bytes per second (0: as fast as the socket takes them)")
    parser.add_argument("--loop", action="store_true", help="repeat the file forever")
    args = parser.parse_args()
    with open(args.file, "rb") as f:
        payload = f.read()
    content_type = "video/mp2t" if args.file.endswith(".ts") else "application/octet-stream"

    class Handler(http.server.BaseHTTPRequestHandler):
        protocol_version = "HTTP/1.0"

        def do_GET(self):
            if self.path.lstrip("/") != os.path.basename(args.file):
                self.send_error(404, "no such stream")
                return
            self.send_response(200)
            self.send_header("Content-Type", content_type)
            if not args.loop:
                self.send_header("Content-Length", str(len(payload)))
            self.end_headers()
            chunk = 4096
            start = time.monotonic()
            sent = 0
            try:
                while True:
                    for offset in range(0, len(payload), chunk):
                        self.wfile.write(payload[offset:offset + chunk])
                        sent += min(chunk, len(payload) - offset)
                        if args.rate > 0:
                            # Pace to the recording rate, as a live camera does.
                            delay = start + sent / args.rate - time.monotonic()
                            if delay > 0:
                                time.sleep(delay)
                    if not args.loop:
                        break
            except (BrokenPipeError, ConnectionResetError):
                pass

        def log_message(self, *unused):
            pass

    class Server(socketserver.ThreadingMixIn, http.server.HTTPServer):
        allow_reuse_address = True
        daemon_threads = True

    with Server(("127.0.0.1", args.port), Handler) as server:
        print("PORT", server.server_address[1], flush=True)
        server.serve_forever()


if __name__ == "__main__":
    sys.exit(main())
