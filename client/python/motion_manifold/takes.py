"""Takes: motions of any length and rate (10 to 1000 Hz) streamed to the
server as a TakeHeader then chunks of frames, and the replies assembled into
numpy arrays (proto/README.md, "Takes")."""

from dataclasses import dataclass, field

import numpy as np

from ._wire import manifold_pb2 as pb
from .motion import AnsweredBy, Motion, codes_from_messages

CHUNK_FRAMES = 2048  # frames a request message (0.8 MB of 99 floats, under gRPC's 4 MB)


@dataclass
class CodeTrack:
    """A take's code track: one code per 6 s window (N x latent) with each
    window's start in seconds and in frames of the take, the take's frames and
    rate, the window length and the hop between starts (seconds)."""

    codes: np.ndarray
    start_seconds: np.ndarray
    start_frames: np.ndarray
    frames: int = 0
    frame_rate: float = 0.0
    window_seconds: float = 0.0
    hop_seconds: float = 0.0
    answered_by: AnsweredBy = field(default_factory=AnsweredBy)

    @classmethod
    def from_windows(cls, windows, **fields):
        return cls(codes_from_messages([w.code for w in windows]),
                   np.array([w.start_seconds for w in windows], dtype=np.float64),
                   np.array([w.start_frame for w in windows], dtype=np.int64), **fields)

    @classmethod
    def from_message(cls, track):
        return cls.from_windows(track.windows, frames=track.frames, frame_rate=track.frame_rate,
                                window_seconds=track.window_seconds, hop_seconds=track.hop_seconds,
                                answered_by=AnsweredBy.from_message(track.answered_by))

    def window_messages(self):
        """The track as DecodeTrack's TakeWindow messages (codes edited or not)."""
        codes = np.asarray(self.codes, dtype=np.float32)
        if codes.ndim != 2 or len(codes) != len(self.start_seconds):
            raise ValueError(f"CodeTrack.codes: shape {codes.shape} for {len(self.start_seconds)} start times, "
                             "expected one code (a row) a start")
        return [pb.TakeWindow(start_seconds=float(s), code=pb.Code(values=c.tolist()))
                for s, c in zip(self.start_seconds, codes)]


@dataclass
class TakeResult:
    """A take's reply: the motion (at the take's rate and length, or 25 Hz with
    at_model_rate), each frame's error in mm (empty for decode_track), the
    summary (frames, input frames, mean and largest error in mm, window and hop
    in seconds) and every window's code. For denoise_take with keep_observed
    and the fitted gap fill: the windows fitted to the take's gaps, the gaps
    they filled, and the gaps beyond the server's bound of fitted windows
    (filled as "matched"); 0 otherwise."""

    motion: Motion
    error_mm: np.ndarray
    input_frames: int
    mean_error_mm: float
    max_error_mm: float
    track: CodeTrack
    answered_by: AnsweredBy
    gap_windows_fitted: int = 0
    gaps_fitted: int = 0
    gaps_over_fit_limit: int = 0


def take_requests(header, chunks):
    """The request stream: the header, then one FrameChunk an array of frames."""
    yield pb.TakeInput(header=header)
    for chunk in chunks:
        chunk = np.asarray(chunk, dtype=np.float32)
        yield pb.TakeInput(chunk=pb.FrameChunk(frames=chunk.shape[0], values=chunk.ravel().tolist()))


def motion_chunks(motion, chunk_frames=CHUNK_FRAMES):
    """A Motion's frames in arrays of at most `chunk_frames`."""
    for first in range(0, motion.frames, chunk_frames):
        yield motion.values[first:first + chunk_frames]


def assemble_take_reply(replies):
    """A TakeResult of a take's reply stream (header, chunks, summary)."""
    header, summary = None, None
    values, errors = [], []
    for reply in replies:
        part = reply.WhichOneof("part")
        if part == "header":
            header = reply.header
        elif part == "chunk":
            values.append(np.asarray(reply.chunk.values, dtype=np.float32))
            errors.append(np.asarray(reply.chunk.error_mm, dtype=np.float32))
        elif part == "summary":
            summary = reply.summary
    if header is None or summary is None:
        raise RuntimeError("the take's reply stream ended without its header or summary")
    columns = header.columns
    frames = np.concatenate(values).reshape(-1, columns) if values else np.zeros((0, columns), np.float32)
    answered_by = AnsweredBy.from_message(header.answered_by)
    track = CodeTrack.from_windows(summary.windows, frames=summary.input_frames, frame_rate=header.frame_rate,
                                   window_seconds=summary.window_seconds, hop_seconds=summary.hop_seconds,
                                   answered_by=answered_by)
    return TakeResult(Motion(frames, header.frame_rate, header.layout),
                      np.concatenate(errors) if errors else np.zeros(0, np.float32), summary.input_frames,
                      summary.mean_error_mm, summary.max_error_mm, track, answered_by,
                      summary.gap_windows_fitted, summary.gaps_fitted, summary.gaps_over_fit_limit)
