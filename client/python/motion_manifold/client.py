"""Client: every rpc of motionmanifold.v1.MotionManifold (proto/README.md)
with numpy arrays in and out.

One Client holds one gRPC channel; its methods may be called from several
threads at once (grpc's channels are thread-safe; the skeleton cache is
filled under a lock). Every refusal or failure of a call raises
MotionManifoldError with the status and the request field the server names;
a malformed local file raises ValueError (BvhError, MotionTextError) naming
the file and line, before any call does work.
"""

import os
import threading
from dataclasses import dataclass

import grpc

from ._wire import manifold_pb2 as pb
from ._wire import manifold_pb2_grpc as pb_grpc
from .bvh import motion_from_bvh, parse_bvh, write_bvh
from .errors import MotionManifoldError
from .motion import (MODEL_RATE, AnsweredBy, Codes, Joined, Motion, Motions, code_messages, codes_from_messages,
                     motion_list, motion_or_code)
from .motion_text import iter_text_chunks, read_text, write_text
from .skeleton import Skeleton
from .takes import CodeTrack, assemble_take_reply, motion_chunks, take_requests

DEFAULT_TIMEOUT = 120.0  # seconds a unary call may take (a model's first load included)


@dataclass
class ClipWindow:
    """ReadClip's reply: a window of a data-root file at 25 Hz (`motion`), from
    `start` counted in the file's own frames, with the file's frame count and
    rate and the last start that gives a full window."""

    path: str
    format: str
    start: int
    file_frames: int
    file_frame_rate: float
    last_start: int
    motion: Motion


def _extension(path):
    return os.path.splitext(str(path))[1].lower()


class Client:
    """A connection to a Motion Manifold server over gRPC.

    address: "host:port" of the server's gRPC port (default localhost:50051).
    token: the bearer token of a server started with --auth-token; sent as
      `authorization: Bearer <token>` (empty: none). Calls that change state,
      and clip reads, need it on such a server.
    root_certificates: for a server with --tls-cert, the PEM certificate(s) to
      trust (bytes, or a file's path); tls=True trusts the system's roots.
      Neither: plaintext.
    timeout: seconds each unary call may take (takes and job watches have none
      unless given).
    """

    def __init__(self, address="localhost:50051", token="", root_certificates=None, tls=False,
                 timeout=DEFAULT_TIMEOUT):
        options = [("grpc.max_receive_message_length", -1), ("grpc.max_send_message_length", -1)]
        if root_certificates is not None or tls:
            if isinstance(root_certificates, (str, os.PathLike)):
                with open(root_certificates, "rb") as f:
                    root_certificates = f.read()
            self.channel = grpc.secure_channel(address, grpc.ssl_channel_credentials(root_certificates), options)
        else:
            self.channel = grpc.insecure_channel(address, options)
        self.stub = pb_grpc.MotionManifoldStub(self.channel)
        self.metadata = [("authorization", f"Bearer {token}")] if token else None
        self.timeout = timeout
        self._skeletons = {}
        self._lock = threading.Lock()

    def close(self):
        self.channel.close()

    def __enter__(self):
        return self

    def __exit__(self, *exception):
        self.close()

    # --- calls

    def _call(self, method, request, timeout=None):
        try:
            return method(request, timeout=timeout or self.timeout, metadata=self.metadata)
        except grpc.RpcError as error:
            raise MotionManifoldError.from_rpc_error(error) from None

    def _stream(self, replies, local_failure=()):
        """The replies of a streaming call, its refusal raised as
        MotionManifoldError; a failure reading the request's frames (a
        malformed file: grpc cancels the call) raised as itself."""
        try:
            yield from replies
        except grpc.RpcError as error:
            if local_failure:
                raise local_failure[0] from None
            raise MotionManifoldError.from_rpc_error(error) from None

    # --- inference: motions and codes

    def encode(self, motions, model=""):
        """The code of each motion (a Motion or a list of them: 150 frames at
        25 Hz or 300 at 50 Hz of the model's layout): Codes with .codes
        (N x latent) and .answered_by."""
        reply = self._call(self.stub.Encode, pb.EncodeRequest(model=model, motions=motion_list(motions)))
        return Codes(codes_from_messages(reply.codes), AnsweredBy.from_message(reply.answered_by))

    def decode(self, codes, model="", decoder="", plant_feet=False):
        """The motion of each code (N x latent, or one code): Motions."""
        request = pb.DecodeRequest(model=model, codes=code_messages(codes), decoder=decoder, plant_feet=plant_feet)
        return Motions.from_message(self._call(self.stub.Decode, request))

    def sample(self, count=1, seed=0, model="", decoder="", plant_feet=False):
        """`count` codes from N(0, I), the same for the same seed, and their motions."""
        request = pb.SampleRequest(model=model, count=count, seed=seed, decoder=decoder, plant_feet=plant_feet)
        return Motions.from_message(self._call(self.stub.Sample, request))

    def interpolate(self, from_, to, steps=2, method="linear", model="", decoder="", plant_feet=False):
        """`steps` codes from `from_` to `to` (each a Motion, encoded first, or
        a code), both included, "linear" or "spherical", and their motions."""
        request = pb.InterpolateRequest(model=model, to=motion_or_code(to, "to"), steps=steps, method=method,
                                        decoder=decoder, plant_feet=plant_feet,
                                        **{"from": motion_or_code(from_, "from_")})
        return Motions.from_message(self._call(self.stub.Interpolate, request))

    def analogy(self, a, b, c, model="", decoder="", plant_feet=False):
        """The motion of a - b + c (each a Motion or a code)."""
        request = pb.AnalogyRequest(model=model, a=motion_or_code(a, "a"), b=motion_or_code(b, "b"),
                                    c=motion_or_code(c, "c"), decoder=decoder, plant_feet=plant_feet)
        return Motions.from_message(self._call(self.stub.Analogy, request))

    def denoise(self, motions, model="", decoder="", zeros_are_missing=False, means_are_missing=False,
                iterations=0, keep_observed=False):
        """The motions projected onto the manifold (NaN values are missing and filled)."""
        request = pb.DenoiseRequest(model=model, motions=motion_list(motions), decoder=decoder,
                                    zeros_are_missing=zeros_are_missing, means_are_missing=means_are_missing,
                                    iterations=iterations, keep_observed=keep_observed)
        return Motions.from_message(self._call(self.stub.Denoise, request))

    def join_clips(self, a, b, transition_seconds=1.0, method="generated", model="", decoder=""):
        """Clips `a` and `b` (Motions of any length at 25 or 50 Hz, the
        model's layout) joined by a transition of `transition_seconds` (0.5
        to 4) in their overlap, "generated" by the manifold or "crossfade":
        a Joined, whose motion is a's frames (at 25 Hz) before the
        transition, the transition, and b's frames after it."""
        for name, clip in (("a", a), ("b", b)):
            if not isinstance(clip, Motion):
                raise TypeError(f"{name}: a {type(clip).__name__}, expected a Motion (values and their frame_rate)")
        request = pb.JoinClipsRequest(model=model, a=a.to_message(), b=b.to_message(),
                                      transition_seconds=transition_seconds, method=method, decoder=decoder)
        return Joined.from_message(self._call(self.stub.JoinClips, request))

    # --- the model store

    def list_models(self):
        """Every model of the store: a list of ModelInfo messages."""
        return list(self._call(self.stub.ListModels, pb.ListModelsRequest()).models)

    def describe_model(self, model=""):
        """One model (empty: the active one) with provenance, evaluation, card and skeleton: ModelInfo."""
        return self._call(self.stub.DescribeModel, pb.DescribeModelRequest(model=model))

    def activate_model(self, model):
        """Makes `model` the active model (needs the token): its ModelInfo."""
        return self._call(self.stub.ActivateModel, pb.ActivateModelRequest(model=model))

    def delete_model(self, model):
        """Takes `model` out of the store (needs the token): its ModelInfo as it was."""
        return self._call(self.stub.DeleteModel, pb.DeleteModelRequest(model=model))

    def skeleton(self, model=""):
        """The skeleton of `model`'s motions (empty: the active model), with the
        layout and BVH layout files of it are read and written in: asked of
        the server (DescribeModel) at each call, so that an activation in
        between is seen, and parsed once per model version."""
        info = self.describe_model(model)
        key = (info.name, info.version)
        with self._lock:
            if key not in self._skeletons:
                self._skeletons[key] = Skeleton.from_model_info(info)
            return self._skeletons[key]

    # --- motion files

    def read_take(self, path, frame_rate=50.0, model=""):
        """A whole motion file as a Motion of the model's layout: text (.txt)
        at `frame_rate` Hz (50: the H3.6M files), or BVH of the model's
        skeleton (.bvh) at its own frame time."""
        if _extension(path) == ".bvh":
            with open(path, "rb") as f:
                parsed = parse_bvh(f.read(), str(path))  # its syntax is checked before the server is asked
            return motion_from_bvh(self.skeleton(model), parsed, str(path))
        if _extension(path) != ".txt":
            raise ValueError(f"{path}: unknown motion file type \"{_extension(path)}\", expected .txt or .bvh")
        skeleton = self.skeleton(model)
        return read_text(path, frame_rate, skeleton.columns, skeleton.layout)

    def read_motion(self, path, start=0, frame_rate=50.0, model="", frames=150):
        """The model's clip (`frames` frames at 25 Hz, 6 s) of a motion file
        from `start` (in 25 Hz frames), as the command-line client and the tool
        take it: text at 50 Hz keeps every second frame, BVH takes the frame
        nearest each 1/25 s."""
        if _extension(path) == ".bvh":
            with open(path, "rb") as f:
                parsed = parse_bvh(f.read(), str(path))
            motion = motion_from_bvh(self.skeleton(model), parsed, str(path), at_model_rate=True)
        else:
            if frame_rate not in (25, 50):
                raise ValueError(f"{path}: rate {frame_rate} Hz is not supported, expected 25 or 50")
            motion = self.read_take(path, frame_rate, model)
            if frame_rate == 50:
                motion = Motion(motion.values[::2], MODEL_RATE, motion.layout)
        if start < 0 or motion.frames < start + frames:
            raise ValueError(f"{path}: too short: {motion.frames} frames at 25 Hz, need {start + frames} "
                             f"({frames} frames from frame {start})")
        return Motion(motion.values[start:start + frames], MODEL_RATE, motion.layout)

    def write_motion(self, motion, path, model=""):
        """Writes a motion as text (.txt, the rate not in the file) or as BVH of
        the model's skeleton at the motion's rate (.bvh)."""
        if _extension(path) == ".bvh":
            write_bvh(motion, self.skeleton(model), path)
        elif _extension(path) == ".txt":
            write_text(motion, path)
        else:
            raise ValueError(f"{path}: unknown motion file type \"{_extension(path)}\", expected .txt or .bvh")

    # --- clips of the server's data root

    def list_clips(self):
        """The data root's motion files: ListClipsReply (.clips, each with path,
        format, size_bytes and uploaded; .truncated)."""
        return self._call(self.stub.ListClips, pb.ListClipsRequest())

    def read_clip(self, path, start=0, model="", whole=False):
        """A window of a data-root file, from `start` in the file's own frames: ClipWindow.
        With `whole`, the whole file at its own rate instead (start 0), as a take of it reads it."""
        reply = self._call(self.stub.ReadClip, pb.ReadClipRequest(model=model, path=path, start=start, whole=whole))
        return ClipWindow(reply.path, reply.format, reply.start, reply.file_frames, reply.file_frame_rate,
                          reply.last_start, Motion.from_message(reply.motion))

    def upload_clip(self, path, content):
        """Writes a new .txt or .bvh file at `path` under the data root (needs
        the token); `content` is its bytes or a local file's path. ClipFile."""
        if isinstance(content, (str, os.PathLike)):
            with open(content, "rb") as f:
                content = f.read()
        return self._call(self.stub.UploadClip, pb.UploadClipRequest(path=path, content=bytes(content)))

    def delete_clip(self, path):
        """Removes an uploaded file (needs the token): its ClipFile as it was."""
        return self._call(self.stub.DeleteClip, pb.DeleteClipRequest(path=path))

    # --- training jobs

    def submit_job(self, dataset, variant="", config_json="", iterations=0, seed=0, hidden=0, batch=0,
                   model_name=""):
        """Queues a training run on `dataset` (a path under the data root);
        needs the token. The Job record."""
        spec = pb.JobSpec(dataset=dataset, variant=variant, config_json=config_json, iterations=iterations,
                          seed=seed, hidden=hidden, batch=batch, model_name=model_name)
        return self._call(self.stub.SubmitJob, pb.SubmitJobRequest(spec=spec))

    def get_job(self, job_id):
        return self._call(self.stub.GetJob, pb.GetJobRequest(id=job_id))

    def list_jobs(self):
        """Every job, newest first: a list of Job messages."""
        return list(self._call(self.stub.ListJobs, pb.ListJobsRequest()).jobs)

    def cancel_job(self, job_id):
        """Cancels a queued or running job (needs the token)."""
        return self._call(self.stub.CancelJob, pb.CancelJobRequest(id=job_id))

    def delete_job(self, job_id):
        """Removes a finished job's record and folder (needs the token); its model stays."""
        return self._call(self.stub.DeleteJob, pb.DeleteJobRequest(id=job_id))

    def watch_job(self, job_id, timeout=None):
        """The job's record now and after every change until it finishes: an iterator of Job messages."""
        return self._stream(self.stub.WatchJob(pb.WatchJobRequest(id=job_id), timeout=timeout,
                                               metadata=self.metadata))

    # --- takes: motions of any length and rate

    def _take_chunks(self, take, frame_rate, model):
        """The header's rate and columns and the frames of a take: a Motion, or
        a file (.txt at `frame_rate`, streamed as it is read; .bvh at its own rate)."""
        if isinstance(take, Motion):
            return take.frame_rate, take.columns, motion_chunks(take)
        if _extension(take) == ".txt":
            columns = self.skeleton(model).columns
            return float(frame_rate or 50.0), columns, iter_text_chunks(take, columns)
        motion = self.read_take(take, model=model)
        return motion.frame_rate, motion.columns, motion_chunks(motion)

    def _take(self, method, take, frame_rate, model, timeout, **header_fields):
        """Calls a take rpc; returns its reply (or reply stream) and the list
        that holds a failure of reading the take's frames, if one happens."""
        rate, columns, chunks = self._take_chunks(take, frame_rate, model)
        header = pb.TakeHeader(model=model, frame_rate=rate, columns=columns, **header_fields)
        local_failure = []

        def requests():
            try:
                yield from take_requests(header, chunks)
            except Exception as error:  # grpc would only log it and cancel the call
                local_failure.append(error)
                raise

        return method(requests(), timeout=timeout, metadata=self.metadata), local_failure

    def encode_take(self, take, frame_rate=None, hop=0.0, model="", timeout=None):
        """The code of every 6 s window of a take (a Motion, or a .txt file at
        `frame_rate` Hz or a .bvh file) every `hop` seconds (0: 3): CodeTrack."""
        local_failure = []
        try:
            future, local_failure = self._take(self.stub.EncodeTake.future, take, frame_rate, model, timeout,
                                               hop_seconds=hop)
            return CodeTrack.from_message(future.result())
        except grpc.RpcError as error:
            if local_failure:
                raise local_failure[0] from None
            raise MotionManifoldError.from_rpc_error(error) from None

    def reconstruct_take(self, take, frame_rate=None, hop=0.0, blend="", decoder="", at_model_rate=False,
                         root="", model="", timeout=None):
        """The take through the manifold window by window, at its rate and
        length (25 Hz with at_model_rate), its root translation kept (root
        "generated": the model's path), with each frame's error: TakeResult."""
        replies, local_failure = self._take(self.stub.ReconstructTake, take, frame_rate, model, timeout,
                                            hop_seconds=hop, blend=blend, decoder=decoder,
                                            at_model_rate=at_model_rate, root=root)
        return assemble_take_reply(self._stream(replies, local_failure))

    def denoise_take(self, take, frame_rate=None, hop=0.0, blend="", decoder="", at_model_rate=False, root="",
                     zeros_are_missing=False, means_are_missing=False, iterations=0, keep_observed=False,
                     model="", timeout=None, gap_fill=""):
        """The take projected onto the manifold window by window, NaN values
        filled (keep_observed: only those): TakeResult. With keep_observed,
        gap_fill says how a gap is filled: "borrowed" ("" means this: the
        take's own stretch most like the gap's surroundings where one is like
        enough, of the whole body or else of the legs and the upper body apart,
        else "fitted"), "fitted" (a code fitted to a 6 s window around
        each gap of 0.6 s or more), "matched", "cubic", "slerp", "hold" or
        "manifold"; the result's
        gap_windows_fitted, gaps_fitted and gaps_over_fit_limit count the
        fitted fill's work."""
        replies, local_failure = self._take(self.stub.DenoiseTake, take, frame_rate, model, timeout,
                                            hop_seconds=hop, blend=blend, decoder=decoder,
                                            at_model_rate=at_model_rate, root=root,
                                            zeros_are_missing=zeros_are_missing,
                                            means_are_missing=means_are_missing, iterations=iterations,
                                            keep_observed=keep_observed, gap_fill=gap_fill)
        return assemble_take_reply(self._stream(replies, local_failure))

    def decode_track(self, track, frame_rate=0.0, frames=0, decoder="", blend="", model="", timeout=None):
        """A code track (a CodeTrack, edited or not) as one continuous motion at
        `frame_rate` Hz (0: 25) of `frames` frames (0: the track's length): TakeResult."""
        request = pb.DecodeTrackRequest(model=model, windows=track.window_messages(), frame_rate=frame_rate,
                                        frames=frames, decoder=decoder, blend=blend)
        replies = self.stub.DecodeTrack(request, timeout=timeout, metadata=self.metadata)
        return assemble_take_reply(self._stream(replies))
