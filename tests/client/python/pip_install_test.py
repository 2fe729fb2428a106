#!/usr/bin/env python3
"""`pip install client/python` from a copy of the checkout's client/python
and proto/ (so the source tree gets no build/ directory), offline
(--no-build-isolation: setuptools and wheel come from the interpreter's
environment), into a temporary target; then, in a fresh interpreter that
sees only that target and the environment's grpcio/protobuf, the client
must import without --proto-path and build requests with the protocol's
current fields. Exits 77 (ctest: skipped) if pip, setuptools, wheel or grpcio
are missing.

    pip_install_test.py SOURCE_DIR
"""
import importlib.util
import os
import shutil
import subprocess
import sys
import tempfile

CHECK = r'''
import sys
import pbgi_client
from pbgi.v1 import pbgi_pb2
assert not any(p.endswith("/python") and "build" in p for p in sys.path), sys.path
assert pbgi_client.__file__.startswith(sys.argv[1]), pbgi_client.__file__
# Generated from this checkout's proto: the newest fields are there.
pbgi_pb2.GatherOptions(dome_visible=False)
pbgi_pb2.BuildOptions(default_light=True)
info = pbgi_pb2.SceneInfo(scene_path="/s.usda")
assert pbgi_client.camera_for(info) == pbgi_client.AUTO_CAMERA
info.cameras.append("/Cam")
assert pbgi_client.camera_for(info) == "/Cam"
assert pbgi_client.camera_for(info, "/Other") == "/Other"
info.cameras.append("/Cam2")
try:
    pbgi_client.camera_for(info)
    raise SystemExit("several cameras and none requested: no error")
except ValueError as e:
    assert "/Cam2" in str(e), e
print("installed client OK")
'''


def main() -> int:
    source = sys.argv[1]
    for module in ("pip", "setuptools", "wheel", "grpc", "google.protobuf"):
        if importlib.util.find_spec(module) is None:
            print(f"{module} is not installed: skipped (pip install -r scripts/requirements.txt)")
            return 77
    with tempfile.TemporaryDirectory(prefix="pbgi-pip-") as tmp:
        checkout = os.path.join(tmp, "checkout")
        shutil.copytree(os.path.join(source, "client", "python"), os.path.join(checkout, "client", "python"),
                        ignore=shutil.ignore_patterns("build", "*.egg-info", "__pycache__"))
        shutil.copytree(os.path.join(source, "proto"), os.path.join(checkout, "proto"))
        target = os.path.join(tmp, "site")
        install = subprocess.run(
            [sys.executable, "-m", "pip", "install", "--no-deps", "--no-build-isolation", "--no-index",
             "--quiet", "--target", target, os.path.join(checkout, "client", "python")],
            capture_output=True, text=True, timeout=240)
        if install.returncode != 0:
            print("pip install client/python failed:\n" + install.stdout + install.stderr)
            return 1
        # The environment's own site-packages (grpcio, protobuf) stay; the
        # build tree's generated module must not be needed.
        env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PBGI_PROTO_PATH")}
        env["PYTHONPATH"] = target
        check = subprocess.run([sys.executable, "-c", CHECK, target], capture_output=True, text=True,
                               timeout=60, env=env, cwd=tmp)
        print(check.stdout + check.stderr)
        return check.returncode


if __name__ == "__main__":
    sys.exit(main())
