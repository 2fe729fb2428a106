#!/usr/bin/env python3
"""The Python client's example against a real pbgid on a temporary unix
socket: it must open the Cornell box, see colour bleeding in the gathered
irradiance, a glossy receiver mirror the red wall, render a lit tile and
get INVALID_ARGUMENT for a NaN receiver.
Exits 77 (ctest: skipped) if grpcio is not installed.

    python_client_test.py PBGID SOURCE_DIR PROTO_PATH
"""
import os
import re
import subprocess
import sys
import tempfile
import time

try:
    import grpc  # noqa: F401
except ImportError:
    print("grpcio is not installed: skipped (pip install -r scripts/requirements.txt)")
    sys.exit(77)


def main() -> int:
    pbgid, source, proto_path = sys.argv[1:4]
    with tempfile.TemporaryDirectory(prefix="pbgi-py-") as tmp:
        socket = os.path.join(tmp, "pbgid.sock")
        log = open(os.path.join(tmp, "pbgid.log"), "w+")
        daemon = subprocess.Popen(
            [pbgid, "--listen", "unix:" + socket, "--cache-dir", os.path.join(tmp, "cache"),
             "--scene-root", os.path.join(source, "scenes"), "--log-level", "warn"],
            stdout=log, stderr=subprocess.STDOUT)
        try:
            deadline = time.time() + 60
            while not os.path.exists(socket):
                if daemon.poll() is not None or time.time() > deadline:
                    log.seek(0)
                    print("pbgid did not start:\n" + log.read())
                    return 1
                time.sleep(0.02)
            env = dict(os.environ, PBGI_PROTO_PATH=proto_path)
            # A small tree keeps the test fast: the daemon's defaults via a
            # relative path exercise the scene-root lookup too.
            result = subprocess.run(
                [sys.executable, os.path.join(source, "client/python/example.py"),
                 "cornell.usda", "--server", "unix:" + socket, "--target-surfels", "20000"],
                capture_output=True, text=True, timeout=120, env=env)
            print(result.stdout)
            print(result.stderr, file=sys.stderr)
            if result.returncode != 0:
                return 1
            out = result.stdout
            values = [tuple(map(float, m)) for m in
                      re.findall(r"irradiance at .*?: ([\d.e+-]+) ([\d.e+-]+) ([\d.e+-]+)", out)]
            glossy = [tuple(map(float, m)) for m in
                      re.findall(r"glossy towards .*?: ([\d.e+-]+) ([\d.e+-]+) ([\d.e+-]+)", out)]
            checks = {
                "three receivers": len(values) == 3,
                "red wall bleeds red": len(values) == 3 and values[0][0] > 1.3 * values[0][1],
                "green wall bleeds green": len(values) == 3 and values[1][1] > 1.3 * values[1][0],
                "tile is lit": bool(re.search(r"mean beauty (0\.0*[1-9]|[1-9])", out)),
                "glossy mirror reflects the red wall": len(glossy) == 1 and glossy[0][0] > 0.0
                and glossy[0][0] > 3.0 * glossy[0][1],
                "NaN refused": "refused as expected: INVALID_ARGUMENT" in out,
                "status": "status: 1 scenes" in out,
            }
            failed = [name for name, ok in checks.items() if not ok]
            for name in failed:
                print(f"FAILED: {name}")
            return 1 if failed else 0
        finally:
            daemon.terminate()
            daemon.wait(timeout=30)


if __name__ == "__main__":
    sys.exit(main())
