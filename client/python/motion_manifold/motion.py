"""Motions and codes as numpy arrays, and their wire messages.

A motion is `values`, a float32 array of frames x columns (row-major as on the
wire), with its frame rate in Hz and the layout of its columns
("h36m-expmap-99": the root's change of position in mm per frame, then 32
joints x 3 exponential-map values in radians). Codes are float32 arrays of
N x 64 (the shipped models' code length).
"""

from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from ._wire import manifold_pb2 as pb

H36M_LAYOUT = "h36m-expmap-99"
MODEL_RATE = 25.0  # Hz of the models' clips and of every motion the server returns


@dataclass
class Motion:
    """A motion: `values` (frames x columns, float32) at `frame_rate` Hz.

    `root` says where the root columns of a motion the server returned come
    from ("generated", "input" or "none"); `contacts` holds, for such a
    motion, a bitmask a frame of the feet planted (bit k for the model's
    ModelInfo.feet[k]), or None.
    """

    values: np.ndarray
    frame_rate: float
    layout: str = H36M_LAYOUT
    root: str = ""
    contacts: Optional[np.ndarray] = None

    def __post_init__(self):
        self.values = np.asarray(self.values, dtype=np.float32)
        if self.values.ndim != 2:
            raise ValueError(f"Motion.values: an array of shape {self.values.shape}, expected frames x columns (2-D)")
        self.frame_rate = float(self.frame_rate)

    @property
    def frames(self):
        return self.values.shape[0]

    @property
    def columns(self):
        return self.values.shape[1]

    @property
    def seconds(self):
        """Its length in seconds, frames / rate."""
        return self.frames / self.frame_rate

    def to_message(self):
        """The wire's Motion message."""
        return pb.Motion(frames=self.frames, columns=self.columns, frame_rate=self.frame_rate, layout=self.layout,
                         values=self.values.ravel().tolist(), root=self.root)

    @classmethod
    def from_message(cls, message):
        values = np.asarray(message.values, dtype=np.float32)
        values = values.reshape(message.frames, message.columns) if message.columns > 0 else values.reshape(0, 0)
        contacts = np.asarray(message.contacts, dtype=np.uint32) if len(message.contacts) else None
        return cls(values, message.frame_rate, message.layout, message.root, contacts)


@dataclass
class AnsweredBy:
    """The model that answered a call: its name in the store and its version (a content hash)."""

    model: str = ""
    version: str = ""

    @classmethod
    def from_message(cls, message):
        return cls(message.model, message.version)


@dataclass
class Motions:
    """The reply of decode, sample, interpolate, analogy and denoise: the
    motions (25 Hz, the model's layout), the codes decoded (N x latent;
    0 rows for decode and denoise) and the model that answered."""

    motions: list
    codes: np.ndarray
    answered_by: AnsweredBy = field(default_factory=AnsweredBy)

    @property
    def values(self):
        """Every motion's values stacked: motions x frames x columns."""
        return np.stack([m.values for m in self.motions]) if self.motions else np.zeros((0, 0, 0), np.float32)

    @classmethod
    def from_message(cls, reply):
        return cls([Motion.from_message(m) for m in reply.motions], codes_from_messages(reply.codes),
                   AnsweredBy.from_message(reply.answered_by))


@dataclass
class Joined:
    """join_clips' reply: the joined motion (25 Hz, the model's layout, root
    "input") and the transition's first and last frame in it (both included)."""

    motion: Motion
    transition_first_frame: int
    transition_last_frame: int
    answered_by: AnsweredBy = field(default_factory=AnsweredBy)

    @classmethod
    def from_message(cls, reply):
        return cls(Motion.from_message(reply.motion), reply.transition_first_frame, reply.transition_last_frame,
                   AnsweredBy.from_message(reply.answered_by))


@dataclass
class Codes:
    """Encode's reply: one code a motion (N x latent) and the model that answered."""

    codes: np.ndarray
    answered_by: AnsweredBy = field(default_factory=AnsweredBy)


def codes_from_messages(messages):
    """Code messages as an N x latent float32 array (N x 0 for none)."""
    if not messages:
        return np.zeros((0, 0), dtype=np.float32)
    return np.stack([np.asarray(c.values, dtype=np.float32) for c in messages])


def code_messages(codes, name="codes"):
    """Code messages of an N x latent array, or of one code (a 1-D array)."""
    array = np.asarray(codes, dtype=np.float32)
    if array.ndim == 1:
        array = array[None, :]
    if array.ndim != 2:
        raise ValueError(f"{name}: an array of shape {array.shape}, expected N x latent (or one code, 1-D)")
    return [pb.Code(values=row.tolist()) for row in array]


def motion_or_code(value, name):
    """A MotionOrCode message of a Motion or a code (a 1-D array of latent values)."""
    if isinstance(value, Motion):
        return pb.MotionOrCode(motion=value.to_message())
    array = np.asarray(value, dtype=np.float32)
    if array.ndim != 1:
        raise ValueError(f"{name}: an array of shape {array.shape}, expected a Motion or one code (1-D)")
    return pb.MotionOrCode(code=pb.Code(values=array.tolist()))


def motion_list(motions, name="motions"):
    """Motion messages of a Motion or a sequence of them."""
    if isinstance(motions, Motion):
        motions = [motions]
    messages = []
    for i, motion in enumerate(motions):
        if not isinstance(motion, Motion):
            raise TypeError(f"{name}[{i}]: a {type(motion).__name__}, expected a Motion (values and their frame_rate)")
        messages.append(motion.to_message())
    return messages
