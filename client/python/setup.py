"""Generates the gRPC stubs of the service's contract while the package is
built, so that they always match proto/ and are never committed.

The stubs are written by Debian's python3-grpc-tools (grpc_tools.protoc) into
the built package as motion_manifold/_wire/manifold_pb2{,_grpc}.py. The
contract is read from MM_PROTO_DIR, or from the repository's proto/ two
folders up (pip builds a local folder in place).
"""

import os
import tempfile

from setuptools import setup
from setuptools.command.build_py import build_py

HERE = os.path.dirname(os.path.abspath(__file__))
PROTO = os.path.join("motionmanifold", "v1", "manifold.proto")


class BuildWithStubs(build_py):
    def run(self):
        super().run()
        proto_dir = os.environ.get("MM_PROTO_DIR") or os.path.join(HERE, "..", "..", "proto")
        if not os.path.exists(os.path.join(proto_dir, PROTO)):
            raise SystemExit(f"motion-manifold: {os.path.join(proto_dir, PROTO)} not found: build from the "
                             "repository's client/python, or set MM_PROTO_DIR to the folder holding " + PROTO)
        try:
            from grpc_tools import protoc  # pylint: disable=import-outside-toplevel
        except ImportError:
            raise SystemExit("motion-manifold: grpc_tools not found: install Debian's python3-grpc-tools") from None
        out_dir = os.path.join(self.build_lib, "motion_manifold", "_wire")
        os.makedirs(out_dir, exist_ok=True)
        with tempfile.TemporaryDirectory() as generated:
            status = protoc.main(["grpc_tools.protoc", "-I", proto_dir, "--python_out", generated,
                                  "--grpc_python_out", generated, os.path.join(proto_dir, PROTO)])
            if status != 0:
                raise SystemExit(f"motion-manifold: grpc_tools.protoc failed on {PROTO} ({status})")
            for name in ("manifold_pb2.py", "manifold_pb2_grpc.py"):
                with open(os.path.join(generated, "motionmanifold", "v1", name), encoding="utf-8") as f:
                    text = f.read()
                # protoc writes the stubs' import of the messages as from the
                # proto's own package; inside this package it is a sibling.
                text = text.replace("from motionmanifold.v1 import manifold_pb2", "from . import manifold_pb2")
                with open(os.path.join(out_dir, name), "w", encoding="utf-8") as f:
                    f.write(text)
        with open(os.path.join(out_dir, "__init__.py"), "w", encoding="utf-8") as f:
            f.write('"""The stubs of proto/motionmanifold/v1/manifold.proto, generated at build time."""\n')


setup(cmdclass={"build_py": BuildWithStubs})
