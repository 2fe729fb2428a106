"""Builds pbgi-client (pyproject.toml holds the metadata): generates the
protocol's message classes (pbgi/v1/{pbgi,scene}_pb2.py) from
proto/pbgi/v1 of this checkout into the build, so an installed client needs
no --proto-path.

protoc is $PBGI_PROTOC, else `protoc` on PATH, else grpcio-tools'
(python -m grpc_tools.protoc). The generated code must match the protobuf
runtime: Debian's protoc 3.21 goes with protobuf 4.21
(scripts/requirements.txt).
"""
import os
import shutil
import subprocess
import sys

from setuptools import setup
from setuptools.command.build_py import build_py

HERE = os.path.dirname(os.path.abspath(__file__))
PROTO_ROOT = os.path.normpath(os.path.join(HERE, "..", "..", "proto"))
PROTOS = ["pbgi/v1/pbgi.proto", "pbgi/v1/scene.proto"]


def _protoc():
    if os.environ.get("PBGI_PROTOC"):
        return [os.environ["PBGI_PROTOC"]]
    if shutil.which("protoc"):
        return ["protoc"]
    try:
        import grpc_tools  # noqa: F401
        return [sys.executable, "-m", "grpc_tools.protoc"]
    except ImportError:
        raise SystemExit("pbgi-client: no protoc found to generate the protocol's Python "
                         "classes: install protobuf-compiler (apt) or grpcio-tools (pip), "
                         "or set PBGI_PROTOC")


class BuildWithMessages(build_py):
    """build_py, plus the generated pbgi.v1 modules in the build tree."""

    def run(self):
        missing = [p for p in PROTOS if not os.path.isfile(os.path.join(PROTO_ROOT, p))]
        if missing:
            raise SystemExit(f"pbgi-client: {', '.join(missing)} not found under {PROTO_ROOT}: "
                             "build the package from a pbgi checkout (pip install client/python)")
        super().run()
        out = self.build_lib
        subprocess.run(_protoc() + ["-I", PROTO_ROOT, f"--python_out={out}"] + PROTOS, check=True)
        for package in ("pbgi", os.path.join("pbgi", "v1")):
            open(os.path.join(out, package, "__init__.py"), "a").close()


# Everything in the build tree goes into the wheel, the generated
# packages with it.
setup(cmdclass={"build_py": BuildWithMessages})
