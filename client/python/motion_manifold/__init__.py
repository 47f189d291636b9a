"""Motion Manifold from Python: a client of the service's gRPC contract
(proto/motionmanifold/v1/manifold.proto) with motions and codes as numpy
arrays, and the motion files it reads and writes (H3.6M text, BVH of a
model's skeleton). See README.md beside this package."""

import importlib

# Said before the first import that needs them, for a Python that lacks
# Debian's packages (another python3 first on the PATH).
for _needed in ("grpc", "numpy"):
    try:
        importlib.import_module(_needed)
    except ImportError as missing:
        raise ImportError(f"motion_manifold needs {_needed}: Debian's python3-grpcio and python3-numpy, seen by "
                          "a Python that has them (/usr/bin/python3, or a virtual environment made from it with "
                          "--system-site-packages: client/python/README.md, \"Install\")") from missing

from .bvh import BvhError, bvh_text, motion_from_bvh, motion_to_bvh, parse_bvh, read_bvh, write_bvh
from .client import Client, ClipWindow
from .errors import MotionManifoldError
from .motion import H36M_LAYOUT, MODEL_RATE, AnsweredBy, Codes, Joined, Motion, Motions
from .motion_text import MotionTextError, read_text, write_text
from .skeleton import Skeleton
from .takes import CodeTrack, TakeResult
from ._wire import manifold_pb2 as messages

__all__ = ["AnsweredBy", "BvhError", "Client", "ClipWindow", "Codes", "CodeTrack", "H36M_LAYOUT", "Joined", "MODEL_RATE",
           "Motion", "MotionManifoldError", "Motions", "MotionTextError", "Skeleton", "TakeResult", "bvh_text",
           "messages", "motion_from_bvh", "motion_to_bvh", "parse_bvh", "read_bvh", "read_text", "write_bvh",
           "write_text"]
