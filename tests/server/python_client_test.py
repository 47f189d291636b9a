#!/usr/bin/python3
"""The gRPC contract from Python, as a Python client uses it.

Generates the stubs of proto/motionmanifold/v1/manifold.proto with Debian's
python3-grpc-tools into a temporary folder, starts the real server binary on
free loopback ports (--grpc-port 0, --ready-file) with a temporary model store
holding the shipped models, and calls every rpc of motionmanifold.v1 with
python3-grpcio, checking that the answers are sane: shapes, the model that
answered, Sample's determinism by seed, a job's life, and the status code and
field of refused requests.

    /usr/bin/python3 tests/server/python_client_test.py --server build/server/motion-manifold-server \
        --proto-dir proto --models models

The real H3.6M clip (S5/walking_1.txt under $MM_DATA_DIR) is required: without
it the test fails, unless MM_ALLOW_MISSING_H36M=1 (then the clip-based checks
use a synthetic motion and say so).
"""

import argparse
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import unittest

import grpc

TOKEN = "secret"
DEFAULT_MODEL = "h36m-dkgm-h100"
SERVICE = "motionmanifold.v1.MotionManifold"
MAX_MESSAGE_BYTES = 4 << 20
ARGS = None  # the command line, parsed in main()


def generate_stubs(proto_dir, out_dir):
    """Runs grpc_tools.protoc on the contract; returns the generated modules."""
    command = [sys.executable, "-m", "grpc_tools.protoc", "-I", proto_dir, "--python_out", out_dir,
               "--grpc_python_out", out_dir, os.path.join(proto_dir, "motionmanifold", "v1", "manifold.proto")]
    subprocess.run(command, check=True)
    sys.path.insert(0, out_dir)
    from motionmanifold.v1 import manifold_pb2, manifold_pb2_grpc  # pylint: disable=import-outside-toplevel
    return manifold_pb2, manifold_pb2_grpc


def h36m_dataset_dir():
    root = os.environ.get("MM_DATA_DIR") or os.path.join(os.path.dirname(__file__), "..", "..", "data")
    nested = os.path.join(root, "h3.6m", "dataset")
    return nested if os.path.isdir(nested) else root


def read_clip_50hz(path, frames=300):
    """The first `frames` lines of an H3.6M text file, as floats."""
    values = []
    with open(path, encoding="utf-8") as lines:
        for _, line in zip(range(frames), lines):
            values.extend(float(v) for v in line.split(","))
    if len(values) != frames * 99:
        raise ValueError(f"{path}: expected {frames} frames of 99 values")
    return values


class Server:
    """The server binary as a child process, ready once its ready file exists."""

    def __init__(self, binary, models_dir, extra_args):
        self.dir = tempfile.mkdtemp(prefix="mm-pyclient-")
        store = os.path.join(self.dir, "models")
        os.makedirs(store)
        for name in ("h36m-dkgm-h100", "h36m-dkgm-cpu"):
            os.symlink(os.path.abspath(os.path.join(models_dir, name)), os.path.join(store, name))
        ready = os.path.join(self.dir, "ready.json")
        self.log_path = os.path.join(self.dir, "server.log")
        argv = [binary, "--grpc-port", "0", "--rest-port", "0", "--address", "127.0.0.1", "--ready-file", ready,
                "--model-store", store] + extra_args
        with open(self.log_path, "wb") as log:
            self.process = subprocess.Popen(argv, stdout=log, stderr=subprocess.STDOUT)  # pylint: disable=consider-using-with
        deadline = time.monotonic() + 180
        while not os.path.exists(ready):
            if self.process.poll() is not None or time.monotonic() > deadline:
                self.stop()
                raise RuntimeError("the server did not become ready:\n" + self.log())
            time.sleep(0.05)
        with open(ready, encoding="utf-8") as f:
            self.grpc_port = json.load(f)["grpc_port"]

    def log(self):
        with open(self.log_path, encoding="utf-8", errors="replace") as f:
            return f.read()

    def stop(self):
        """SIGTERM; returns the exit status."""
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGTERM)
            try:
                self.process.wait(timeout=60)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        return self.process.returncode

    def cleanup(self):
        shutil.rmtree(self.dir, ignore_errors=True)


class PythonClientTest(unittest.TestCase):
    """Every rpc of motionmanifold.v1.MotionManifold through python3-grpcio."""

    @classmethod
    def setUpClass(cls):
        cls.stub_dir = tempfile.mkdtemp(prefix="mm-pystubs-")
        cls.pb, cls.pb_grpc = generate_stubs(ARGS.proto_dir, cls.stub_dir)
        cls.state_dir = tempfile.mkdtemp(prefix="mm-pystate-")
        dataset_dir = h36m_dataset_dir()
        clip = os.path.join(dataset_dir, "S5", "walking_1.txt")
        if os.path.exists(clip):
            cls.clip = read_clip_50hz(clip)
        elif os.environ.get("MM_ALLOW_MISSING_H36M") == "1":
            print(f"H3.6M not found ({clip}): using a synthetic motion", file=sys.stderr)
            cls.clip = [0.01 * math.sin(0.1 * i) for i in range(300 * 99)]
        else:
            raise RuntimeError(f"H3.6M not found: {clip} (run scripts/extract-h36m.sh, or set MM_ALLOW_MISSING_H36M=1)")
        # Training jobs and clips on a small text tree (one S1 and one S5 file,
        # copied: a link out of the data root is not one of its clips), which
        # a job prepares in a moment.
        data_root = os.path.join(cls.state_dir, "data")
        for subject in ("S1", "S5"):
            os.makedirs(os.path.join(data_root, "h36m", subject))
            source = os.path.abspath(os.path.join(dataset_dir, subject, "walking_1.txt"))
            if os.path.exists(source):
                shutil.copyfile(source, os.path.join(data_root, "h36m", subject, "walking_1.txt"))
        cls.server = Server(ARGS.server, ARGS.models,
                            ["--auth-token", TOKEN, "--max-message-bytes", str(MAX_MESSAGE_BYTES),
                             "--state-dir", os.path.join(cls.state_dir, "state"), "--data-root", data_root])
        cls.dataset_name = "h36m"
        options = [("grpc.max_receive_message_length", -1), ("grpc.max_send_message_length", -1)]
        cls.channel = grpc.insecure_channel(f"127.0.0.1:{cls.server.grpc_port}", options=options)
        cls.stub = cls.pb_grpc.MotionManifoldStub(cls.channel)

    @classmethod
    def tearDownClass(cls):
        cls.channel.close()
        status = cls.server.stop()
        log = cls.server.log()
        cls.server.cleanup()
        shutil.rmtree(cls.stub_dir, ignore_errors=True)
        shutil.rmtree(cls.state_dir, ignore_errors=True)
        if status != 0:
            raise AssertionError(f"the server exited with {status}:\n{log}")

    # --- helpers

    def motion(self, values=None, frames=300, rate=50.0):
        return self.pb.Motion(frames=frames, columns=99, frame_rate=rate, layout="h36m-expmap-99",
                              values=self.clip if values is None else values)

    def assert_refused(self, call, request, code, field, token=None):
        metadata = [("authorization", f"Bearer {token}")] if token else None
        with self.assertRaises(grpc.RpcError) as raised:
            call(request, timeout=120, metadata=metadata)
        error = raised.exception
        self.assertEqual(error.code(), code, error.details())
        if field:
            self.assertTrue(error.details().startswith(field + ": "), error.details())
            self.assertIn(("mm-error-field", field), list(error.trailing_metadata() or []))

    def assert_motion_shape(self, motion):
        self.assertEqual((motion.frames, motion.columns, motion.frame_rate, motion.layout),
                         (150, 99, 25.0, "h36m-expmap-99"))
        self.assertEqual(len(motion.values), 150 * 99)
        self.assertTrue(all(math.isfinite(v) for v in motion.values))

    def code_of_clip(self):
        reply = self.stub.Encode(self.pb.EncodeRequest(motions=[self.motion()]), timeout=120)
        return reply.codes[0]

    # --- inference

    def test_encode_gives_one_code_per_motion_from_the_default_model(self):
        reply = self.stub.Encode(self.pb.EncodeRequest(motions=[self.motion(), self.motion()]), timeout=120)
        self.assertEqual(reply.answered_by.model, DEFAULT_MODEL)
        self.assertEqual(len(reply.answered_by.version), 16)
        self.assertEqual(len(reply.codes), 2)
        self.assertEqual(len(reply.codes[0].values), 64)
        for a, b in zip(reply.codes[0].values, reply.codes[1].values):
            self.assertAlmostEqual(a, b, delta=1e-4)

    def test_decode_gives_a_motion_per_code(self):
        code = self.code_of_clip()
        for decoder in ("", "rotation", "velocity"):
            reply = self.stub.Decode(self.pb.DecodeRequest(codes=[code], decoder=decoder), timeout=120)
            self.assertEqual(len(reply.motions), 1, decoder)
            self.assert_motion_shape(reply.motions[0])
            self.assertEqual(len(reply.codes), 0)

    def test_sample_is_determined_by_its_seed(self):
        request = self.pb.SampleRequest(count=2, seed=7)
        first = self.stub.Sample(request, timeout=120)
        second = self.stub.Sample(request, timeout=120)
        other = self.stub.Sample(self.pb.SampleRequest(count=2, seed=8), timeout=120)
        self.assertEqual(len(first.motions), 2)
        self.assertEqual(len(first.codes), 2)
        for motion in first.motions:
            self.assert_motion_shape(motion)
        self.assertEqual(first.codes[0].values, second.codes[0].values)
        self.assertNotEqual(first.codes[0].values, other.codes[0].values)
        for a, b in zip(first.motions[1].values, second.motions[1].values):
            self.assertAlmostEqual(a, b, delta=1e-4)
        self.assertEqual(len(self.stub.Sample(self.pb.SampleRequest(), timeout=120).motions), 1)  # count unset: one

    def test_interpolate_runs_from_its_first_end_to_its_last(self):
        a = self.pb.Code(values=[(-1.0) ** i for i in range(64)])
        b = self.pb.Code(values=[1.0] * 64)
        for method in ("", "linear", "spherical"):
            reply = self.stub.Interpolate(self.pb.InterpolateRequest(
                **{"from": self.pb.MotionOrCode(code=a)}, to=self.pb.MotionOrCode(code=b), steps=3, method=method),
                timeout=120)
            self.assertEqual(len(reply.motions), 3, method)
            self.assertEqual(len(reply.codes), 3, method)
            for got, want in zip(reply.codes[0].values, a.values):
                self.assertAlmostEqual(got, want, delta=1e-5)
            for got in reply.codes[2].values:
                self.assertAlmostEqual(got, 1.0, delta=1e-5)
        # A motion at one end is encoded first.
        reply = self.stub.Interpolate(self.pb.InterpolateRequest(
            **{"from": self.pb.MotionOrCode(motion=self.motion())}, to=self.pb.MotionOrCode(code=b)), timeout=120)
        self.assertEqual(len(reply.motions), 2)  # steps unset: two

    def test_analogy_decodes_a_minus_b_plus_c(self):
        codes = [self.pb.Code(values=[float(k)] * 64) for k in (0.5, 0.25, -0.5)]
        reply = self.stub.Analogy(self.pb.AnalogyRequest(a=self.pb.MotionOrCode(code=codes[0]),
                                                         b=self.pb.MotionOrCode(code=codes[1]),
                                                         c=self.pb.MotionOrCode(code=codes[2])), timeout=120)
        self.assertEqual(len(reply.motions), 1)
        self.assert_motion_shape(reply.motions[0])
        for v in reply.codes[0].values:
            self.assertAlmostEqual(v, -0.25, delta=1e-6)

    def test_denoise_keeps_the_input_root_translation(self):
        reply = self.stub.Denoise(self.pb.DenoiseRequest(motions=[self.motion()]), timeout=120)
        self.assertEqual(len(reply.motions), 1)
        self.assert_motion_shape(reply.motions[0])
        self.assertAlmostEqual(reply.motions[0].values[0], self.clip[0], delta=1e-4)

    # --- models

    def test_models_are_listed_described_and_activated_with_the_token(self):
        models = {m.name: m for m in self.stub.ListModels(self.pb.ListModelsRequest(), timeout=60).models}
        self.assertIn(DEFAULT_MODEL, models)
        self.assertIn("h36m-dkgm-cpu", models)
        self.assertTrue(models[DEFAULT_MODEL].active)
        info = self.stub.DescribeModel(self.pb.DescribeModelRequest(model=""), timeout=60)
        self.assertEqual(info.name, DEFAULT_MODEL)
        self.assertIsInstance(json.loads(info.evaluation_json), dict)
        self.assertTrue(info.model_card)
        skeleton = json.loads(info.skeleton_json)
        self.assertEqual(skeleton["name"], "h36m-32")
        self.assertEqual(len(skeleton["joints"]), 32)
        self.assert_refused(self.stub.DescribeModel, self.pb.DescribeModelRequest(model="nope"),
                            grpc.StatusCode.NOT_FOUND, "model")
        # Activating the model that is already active changes nothing but still needs the token.
        request = self.pb.ActivateModelRequest(model=DEFAULT_MODEL)
        self.assert_refused(self.stub.ActivateModel, request, grpc.StatusCode.UNAUTHENTICATED, "authorization")
        self.assert_refused(self.stub.ActivateModel, request, grpc.StatusCode.UNAUTHENTICATED, "authorization",
                            token="wrong")
        info = self.stub.ActivateModel(request, timeout=120, metadata=[("authorization", f"Bearer {TOKEN}")])
        self.assertTrue(info.active)

    # --- clips of the data root

    def test_clips_of_the_data_root_are_listed_and_read_as_every_second_row(self):
        if not os.path.exists(os.path.join(h36m_dataset_dir(), "S5", "walking_1.txt")):
            self.skipTest("H3.6M not found: the data root holds no clips")
        # The data root is the operator's: read with the token.
        self.assert_refused(self.stub.ListClips, self.pb.ListClipsRequest(), grpc.StatusCode.UNAUTHENTICATED,
                            "authorization")
        bearer = [("authorization", f"Bearer {TOKEN}")]
        listed = self.stub.ListClips(self.pb.ListClipsRequest(), timeout=60, metadata=bearer)
        self.assertEqual([(c.path, c.format) for c in listed.clips],
                         [("h36m/S1/walking_1.txt", "h36m-text"), ("h36m/S5/walking_1.txt", "h36m-text")])
        self.assertFalse(listed.truncated)
        window = self.stub.ReadClip(self.pb.ReadClipRequest(path="h36m/S5/walking_1.txt"), timeout=60,
                                    metadata=bearer)
        self.assertEqual((window.start, window.file_frame_rate), (0, 50.0))
        self.assertEqual(window.last_start, window.file_frames - 300)
        self.assert_motion_shape(window.motion)
        every_second_row = [v for f in range(0, 300, 2) for v in self.clip[f * 99:(f + 1) * 99]]
        for got, row_value in zip(window.motion.values, every_second_row):
            self.assertTrue(math.isclose(got, row_value, rel_tol=1e-6, abs_tol=1e-7), (got, row_value))
        # It encodes to the code of the raw 50 Hz rows.
        encoded = self.stub.Encode(self.pb.EncodeRequest(motions=[window.motion]), timeout=120)
        self.assertEqual(list(encoded.codes[0].values), list(self.code_of_clip().values))
        self.assert_refused(self.stub.ReadClip, self.pb.ReadClipRequest(path="../outside.txt"),
                            grpc.StatusCode.INVALID_ARGUMENT, "path", token=TOKEN)
        self.assert_refused(self.stub.ReadClip,
                            self.pb.ReadClipRequest(path="h36m/S5/walking_1.txt", start=window.last_start + 1),
                            grpc.StatusCode.INVALID_ARGUMENT, "start", token=TOKEN)

    # --- jobs

    def test_a_job_is_submitted_watched_listed_and_cancelled(self):
        spec = self.pb.JobSpec(dataset=self.dataset_name, iterations=1000000, hidden=16, batch=4, seed=1)
        auth = [("authorization", f"Bearer {TOKEN}")]
        self.assert_refused(self.stub.SubmitJob, self.pb.SubmitJobRequest(spec=spec),
                            grpc.StatusCode.UNAUTHENTICATED, "authorization")
        job = self.stub.SubmitJob(self.pb.SubmitJobRequest(spec=spec), timeout=60, metadata=auth)
        self.assertIn(job.state, ("queued", "running"))
        self.assertEqual(job.spec.variant, "DKGM")  # unset: the default variant
        self.assertEqual(self.stub.GetJob(self.pb.GetJobRequest(id=job.id), timeout=60).id, job.id)
        self.assertIn(job.id, [j.id for j in self.stub.ListJobs(self.pb.ListJobsRequest(), timeout=60).jobs])

        stream = self.stub.WatchJob(self.pb.WatchJobRequest(id=job.id), timeout=300)
        first = next(stream)
        self.assertEqual(first.id, job.id)
        self.assert_refused(self.stub.CancelJob, self.pb.CancelJobRequest(id=job.id),
                            grpc.StatusCode.UNAUTHENTICATED, "authorization")
        threading.Timer(0.5, lambda: self.stub.CancelJob(self.pb.CancelJobRequest(id=job.id), timeout=60,
                                                         metadata=auth)).start()
        states = [first.state] + [event.state for event in stream]
        self.assertEqual(states[-1], "cancelled", states)
        self.assert_refused(self.stub.GetJob, self.pb.GetJobRequest(id="no-such-job"), grpc.StatusCode.NOT_FOUND, "")

        # Deleted once its run has stopped: the record is gone.
        delete = self.pb.DeleteJobRequest(id=job.id)
        self.assert_refused(self.stub.DeleteJob, delete, grpc.StatusCode.UNAUTHENTICATED, "authorization")
        for _ in range(300):
            try:
                self.assertEqual(self.stub.DeleteJob(delete, timeout=60, metadata=auth).state, "cancelled")
                break
            except grpc.RpcError as error:
                self.assertEqual(error.code(), grpc.StatusCode.FAILED_PRECONDITION, error.details())
                time.sleep(0.2)
        self.assert_refused(self.stub.GetJob, self.pb.GetJobRequest(id=job.id), grpc.StatusCode.NOT_FOUND, "id")

    def test_the_active_model_and_the_operators_clips_are_not_deleted(self):
        self.assert_refused(self.stub.DeleteModel, self.pb.DeleteModelRequest(model=DEFAULT_MODEL),
                            grpc.StatusCode.UNAUTHENTICATED, "authorization")
        self.assert_refused(self.stub.DeleteModel, self.pb.DeleteModelRequest(model=DEFAULT_MODEL),
                            grpc.StatusCode.FAILED_PRECONDITION, "model", token=TOKEN)
        self.assert_refused(self.stub.DeleteClip, self.pb.DeleteClipRequest(path="../outside.txt"),
                            grpc.StatusCode.INVALID_ARGUMENT, "path", token=TOKEN)

    # --- refusals and the standard services

    def test_bad_requests_get_their_code_and_field(self):
        self.assert_refused(self.stub.Encode, self.pb.EncodeRequest(motions=[self.motion(frames=200)]),
                            grpc.StatusCode.INVALID_ARGUMENT, "motions[0].frames")
        self.assert_refused(self.stub.Encode, self.pb.EncodeRequest(motions=[self.motion(rate=30.0)]),
                            grpc.StatusCode.INVALID_ARGUMENT, "motions[0].frame_rate")
        self.assert_refused(self.stub.Decode, self.pb.DecodeRequest(codes=[self.pb.Code(values=[0.0] * 3)]),
                            grpc.StatusCode.INVALID_ARGUMENT, "codes[0]")
        self.assert_refused(self.stub.Sample, self.pb.SampleRequest(decoder="nope"),
                            grpc.StatusCode.INVALID_ARGUMENT, "decoder")
        self.assert_refused(self.stub.Sample, self.pb.SampleRequest(model="nope"), grpc.StatusCode.NOT_FOUND, "model")
        too_large = self.motion(values=[0.0] * (MAX_MESSAGE_BYTES // 4 + 1000))
        self.assert_refused(self.stub.Encode, self.pb.EncodeRequest(motions=[too_large]),
                            grpc.StatusCode.RESOURCE_EXHAUSTED, "")
        self.assertEqual(len(self.code_of_clip().values), 64)  # still serving

    def test_health_reports_serving(self):
        # grpc.health.v1 by hand: HealthCheckRequest{service} is field 1 (a
        # string), HealthCheckResponse{status} field 1 (SERVING = 1).
        check = self.channel.unary_unary("/grpc.health.v1.Health/Check",
                                         request_serializer=lambda service: (
                                             b"" if not service else
                                             b"\x0a" + bytes([len(service)]) + service.encode()),
                                         response_deserializer=lambda data: data)
        for service in ("", SERVICE):
            self.assertEqual(check(service, timeout=30), b"\x08\x01", service)


def main():
    global ARGS  # pylint: disable=global-statement
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--server", required=True, help="the motion-manifold-server binary")
    parser.add_argument("--proto-dir", required=True, help="the folder holding motionmanifold/v1/manifold.proto")
    parser.add_argument("--models", required=True, help="the folder of the shipped models")
    ARGS, rest = parser.parse_known_args()
    unittest.main(argv=[sys.argv[0]] + rest, verbosity=2)


if __name__ == "__main__":
    main()
