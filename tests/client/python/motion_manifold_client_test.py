#!/usr/bin/python3
"""The Python client (client/python, package motion_manifold) as a researcher
installs and uses it, against the real server.

The package is installed as its README says, into a virtual environment
(--system-site-packages, so Debian's grpcio, protobuf and numpy) in a
temporary folder, built from a copy of client/python with its stubs
generated from proto/ and nothing downloaded; the test then runs again under
that environment's python, importing the installed package. Two real
servers on free loopback ports with the shipped models: one with a bearer
token, a data root and a state folder (every rpc, numpy shapes and rates,
takes from arrays and files, BVH both ways against the server's own
conversion, the token, refusals carrying their field), one with TLS.

    /usr/bin/python3 tests/client/python/motion_manifold_client_test.py --server build/server/motion-manifold-server \
        --package client/python --proto-dir proto --models models --shared-dir ../shared

The real H3.6M file S5/walking_1.txt (under $MM_DATA_DIR) is required;
without it the test fails, or with MM_ALLOW_MISSING_H36M=1 exits 77 (skipped).
"""

import argparse
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import unittest
import urllib.request

TOKEN = "python-client-secret"
DEFAULT_MODEL = "h36m-dkgm-h100"
SKIPPED = 77
MAX_MESSAGE_BYTES = 4 << 20
ARGS = None


def h36m_dataset_dir():
    root = os.environ.get("MM_DATA_DIR") or os.path.join(os.path.dirname(__file__), "..", "..", "..", "data")
    nested = os.path.join(root, "h3.6m", "dataset")
    return os.path.abspath(nested if os.path.isdir(nested) else root)


def install_and_rerun():
    """Installs the package as the README does, into a new virtual environment,
    and runs this file again under its python; returns that run's status."""
    work = tempfile.mkdtemp(prefix="mm-pypkg-")
    source = os.path.join(work, "source")
    # A copy, so that the build's own folders (build/, *.egg-info) stay out of the source tree.
    shutil.copytree(ARGS.package, source, ignore=shutil.ignore_patterns("build", "*.egg-info", "__pycache__"))
    venv = os.path.join(work, "venv")
    started = time.monotonic()
    environment = dict(os.environ, MM_PROTO_DIR=os.path.abspath(ARGS.proto_dir))
    # The package README's line, the one README.md gives too, with this folder's paths.
    with open(os.path.join(ARGS.package, "README.md"), encoding="utf-8") as f:
        line = re.search(r"## Install.*?```sh\n(.*?)\n```", f.read(), re.S).group(1)
    with open(os.path.join(ARGS.package, "..", "..", "README.md"), encoding="utf-8") as f:
        if line not in f.read():
            raise SystemExit(f"README.md does not install the Python client with client/python/README.md's line: {line}")
    install = line.replace("~/.venvs/motion-manifold", venv).replace("./client/python", source)
    if install == line:
        raise SystemExit(f"client/python/README.md's install line changed its paths: {line}")
    subprocess.run(install + " --quiet", shell=True, check=True, env=environment)
    print(f"installed in {time.monotonic() - started:.1f} s", flush=True)
    shutil.rmtree(source)
    status = subprocess.run([os.path.join(venv, "bin", "python"), os.path.abspath(__file__), "--installed-in", venv]
                            + sys.argv[1:], check=False).returncode
    shutil.rmtree(work, ignore_errors=True)
    return status


class Server:
    """The server binary as a child process, ready once its ready file exists."""

    def __init__(self, extra_args, store_models=(DEFAULT_MODEL, "h36m-dkgm-cpu")):
        self.dir = tempfile.mkdtemp(prefix="mm-pyclient-server-")
        self.store = os.path.join(self.dir, "models")
        os.makedirs(self.store)
        for name in store_models:
            os.symlink(os.path.abspath(os.path.join(ARGS.models, name)), os.path.join(self.store, name))
        self.ready = os.path.join(self.dir, "ready.json")
        self.log_path = os.path.join(self.dir, "server.log")
        # One LibTorch thread, as takes_service_tests run: on the 2-core test
        # machine beside other builds (load 7) one Encode took 1.25 s of the
        # server's CPU with two threads contending and 0.06 s with one.
        argv = [ARGS.server, "--grpc-port", "0", "--rest-port", "0", "--address", "127.0.0.1", "--ready-file",
                self.ready, "--model-store", self.store, "--threads", "1"] + extra_args
        with open(self.log_path, "wb") as log:
            self.process = subprocess.Popen(argv, stdout=log, stderr=subprocess.STDOUT)  # pylint: disable=consider-using-with

    def wait_ready(self):
        deadline = time.monotonic() + 180
        while not os.path.exists(self.ready):
            if self.process.poll() is not None or time.monotonic() > deadline:
                self.stop()
                raise RuntimeError("the server did not become ready:\n" + self.log())
            time.sleep(0.05)
        with open(self.ready, encoding="utf-8") as f:
            ready = json.load(f)
        self.grpc_address = f"127.0.0.1:{ready['grpc_port']}"
        self.rest_url = f"http://127.0.0.1:{ready['rest_port']}"
        return self

    def log(self):
        with open(self.log_path, encoding="utf-8", errors="replace") as f:
            return f.read()

    def cpu_seconds(self):
        """The server's CPU time so far (user and system, /proc/PID/stat)."""
        with open(f"/proc/{self.process.pid}/stat", encoding="ascii") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")

    def stop(self):
        """SIGTERM; returns the exit status."""
        if self.process.poll() is None:
            # Printed, not asserted: what the calls cost the server, whatever the machine's load.
            print(f"server {self.process.pid}: {self.cpu_seconds():.1f} s of CPU", file=sys.stderr, flush=True)
            self.process.send_signal(signal.SIGTERM)
            try:
                self.process.wait(timeout=60)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        return self.process.returncode


SERVERS = {}


def setUpModule():  # pylint: disable=invalid-name
    state = tempfile.mkdtemp(prefix="mm-pyclient-state-")
    SERVERS["state"] = state
    # The data root: an S1 and an S5 file, copied (a link out of the root is
    # not one of its clips), which a job prepares in a moment.
    data_root = os.path.join(state, "data")
    for subject in ("S1", "S5"):
        os.makedirs(os.path.join(data_root, "h36m", subject))
        shutil.copyfile(os.path.join(h36m_dataset_dir(), subject, "walking_1.txt"),
                        os.path.join(data_root, "h36m", subject, "walking_1.txt"))
    cert, key = os.path.join(state, "cert.pem"), os.path.join(state, "key.pem")
    subprocess.run(["openssl", "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "1", "-subj", "/CN=localhost",
                    "-addext", "subjectAltName=IP:127.0.0.1,DNS:localhost", "-keyout", key, "-out", cert],
                   check=True, capture_output=True)
    SERVERS["cert"] = cert
    # Both start at once; each loads the default model.
    main = Server(["--auth-token", TOKEN, "--state-dir", os.path.join(state, "state"), "--data-root", data_root,
                   "--max-message-bytes", str(MAX_MESSAGE_BYTES)])
    tls = Server(["--tls-cert", cert, "--tls-key", key], store_models=("h36m-dkgm-cpu",))
    SERVERS["main"], SERVERS["tls"] = main.wait_ready(), tls.wait_ready()


def tearDownModule():  # pylint: disable=invalid-name
    failures = []
    for name in ("main", "tls"):
        server = SERVERS.get(name)
        if server is None:
            continue
        status = server.stop()
        if status != 0:
            failures.append(f"the {name} server exited with {status}:\n{server.log()}")
        shutil.rmtree(server.dir, ignore_errors=True)
    shutil.rmtree(SERVERS.get("state", ""), ignore_errors=True)
    if failures:
        raise AssertionError("\n".join(failures))


def bvh_world_positions(bvh, frame):
    """Every joint's world position (file units) at `frame`, as BVH readers
    compute it: column vectors, a joint's rotation channels multiplied in
    file order, position channels added to its offset."""
    import numpy as np  # pylint: disable=import-outside-toplevel
    values = bvh.values[frame]
    positions, rotations, next_value = [], [], 0
    for joint in bvh.joints:
        local_position, local = np.array(joint.offset, dtype=np.float64), np.eye(3)
        for channel in joint.channels:
            value, next_value = values[next_value], next_value + 1
            axis = "XYZ".index(channel[0])
            if channel.endswith("position"):
                local_position[axis] += value
            else:
                c, s = np.cos(np.radians(value)), np.sin(np.radians(value))
                turn = np.eye(3)
                i, j = [(1, 2), (2, 0), (0, 1)][axis]
                turn[i, i], turn[i, j], turn[j, i], turn[j, j] = c, -s, s, c
                local = local @ turn
        if joint.parent < 0:
            positions.append(local_position)
            rotations.append(local)
        else:
            positions.append(positions[joint.parent] + rotations[joint.parent] @ local_position)
            rotations.append(rotations[joint.parent] @ local)
    return np.array(positions)


class PythonClientTest(unittest.TestCase):
    """Every rpc of motionmanifold.v1 through the installed motion_manifold package."""

    @classmethod
    def setUpClass(cls):
        import numpy as np  # pylint: disable=import-outside-toplevel
        import motion_manifold as mm  # pylint: disable=import-outside-toplevel
        import grpc  # pylint: disable=import-outside-toplevel
        cls.np, cls.mm, cls.grpc = np, mm, grpc
        cls.server = SERVERS["main"]
        cls.client = mm.Client(cls.server.grpc_address, token=TOKEN)
        cls.anonymous = mm.Client(cls.server.grpc_address)
        cls.walk = os.path.join(h36m_dataset_dir(), "S5", "walking_1.txt")
        cls.scratch = tempfile.mkdtemp(prefix="mm-pyclient-files-")

    @classmethod
    def tearDownClass(cls):
        cls.client.close()
        cls.anonymous.close()
        shutil.rmtree(cls.scratch, ignore_errors=True)

    def setUp(self):
        self.started, self.server_cpu = time.monotonic(), self.server.cpu_seconds()

    def tearDown(self):
        # Printed, not asserted: the machine's load decides the wall time.
        print(f"  {self._testMethodName}: {time.monotonic() - self.started:.2f} s, the server's CPU "
              f"{self.server.cpu_seconds() - self.server_cpu:.2f} s", file=sys.stderr, flush=True)

    def assert_refused(self, call, code, field):
        with self.assertRaises(self.mm.MotionManifoldError) as raised:
            call()
        error = raised.exception
        self.assertEqual((error.code, error.field), (code, field), error.message)
        self.assertEqual(error.status, code.name)
        if field:
            self.assertTrue(error.message.startswith(field + ": "), error.message)
        return error

    def assert_model_motions(self, reply, count):
        self.assertEqual(reply.values.shape, (count, 150, 99))
        for motion in reply.motions:
            self.assertEqual((motion.frame_rate, motion.layout, motion.values.dtype), (25.0, "h36m-expmap-99",
                                                                                     self.np.float32))
        self.assertTrue(self.np.all(self.np.isfinite(reply.values)))
        self.assertEqual(reply.answered_by.model, DEFAULT_MODEL)

    # --- the package

    def test_the_package_is_the_installed_one_with_stubs_of_the_contract(self):
        installed_in = os.path.realpath(ARGS.installed_in)
        self.assertTrue(os.path.realpath(self.mm.__file__).startswith(installed_in), self.mm.__file__)
        self.assertEqual(self.mm.messages.DESCRIPTOR.name, "motionmanifold/v1/manifold.proto")

    # --- inference

    def test_encode_gives_an_n_by_64_array_the_same_at_50_and_25_hz(self):
        np, mm = self.np, self.mm
        clip = self.client.read_motion(self.walk)  # 150 frames at 25 Hz: every second row from the first
        self.assertEqual((clip.frames, clip.columns, clip.frame_rate), (150, 99, 25.0))
        rows = mm.read_text(self.walk)
        self.assertEqual((rows.columns, rows.frame_rate), (99, 50.0))
        np.testing.assert_array_equal(clip.values, rows.values[0:300:2])
        encoded = self.client.encode([clip, mm.Motion(rows.values[:300], 50)])
        self.assertEqual(encoded.codes.shape, (2, 64))
        self.assertEqual(encoded.codes.dtype, np.float32)
        self.assertEqual(encoded.answered_by.model, DEFAULT_MODEL)
        self.assertEqual(len(encoded.answered_by.version), 16)
        np.testing.assert_array_equal(encoded.codes[0], encoded.codes[1])

    def test_decode_sample_interpolate_analogy_and_denoise_answer_numpy_motions(self):
        np = self.np
        clip = self.client.read_motion(self.walk)
        code = self.client.encode(clip).codes[0]
        sampled = self.client.sample(count=3, seed=7)
        self.assert_model_motions(sampled, 3)
        self.assertEqual(sampled.codes.shape, (3, 64))
        decoded = self.client.decode(sampled.codes[1:])  # an N x 64 array: the motions Sample gave
        self.assert_model_motions(decoded, 2)
        self.assertEqual(decoded.codes.shape[0], 0)
        np.testing.assert_allclose(decoded.values, sampled.values[1:], atol=1e-4)

        path = self.client.interpolate(clip, sampled.codes[0], steps=3, method="spherical")
        self.assert_model_motions(path, 3)
        np.testing.assert_allclose(path.codes[0], code, atol=1e-5)  # the motion's end is its code
        np.testing.assert_allclose(path.codes[-1], sampled.codes[0], atol=1e-5)

        analogy = self.client.analogy(sampled.codes[0], sampled.codes[1], sampled.codes[2])
        self.assert_model_motions(analogy, 1)
        np.testing.assert_allclose(analogy.codes[0], sampled.codes[0] - sampled.codes[1] + sampled.codes[2],
                                   atol=1e-5)

        noisy = clip.values.copy()
        noisy[::3, 3:] = 0  # every third frame's joints missing
        denoised = self.client.denoise(self.mm.Motion(noisy, 25), zeros_are_missing=True, keep_observed=True)
        self.assert_model_motions(denoised, 1)
        observed = noisy != 0
        np.testing.assert_allclose(denoised.values[0][observed], noisy[observed], atol=1e-6)
        self.assertEqual(denoised.motions[0].root, "input")

    # --- the model store

    def test_join_clips_keeps_both_clips_around_a_transition_of_one_second(self):
        np, mm = self.np, self.mm
        rows = mm.read_text(self.walk).values
        a, b = mm.Motion(rows[:200], 50), mm.Motion(rows[400:600], 50)  # 4 s each: 100 frames at 25 Hz
        joined = self.client.join_clips(a, b, transition_seconds=1.0, method="crossfade")
        self.assertEqual((joined.transition_first_frame, joined.transition_last_frame), (75, 99))
        self.assertEqual((joined.motion.frames, joined.motion.frame_rate, joined.motion.root), (175, 25.0, "input"))
        np.testing.assert_array_equal(joined.motion.values[:75], rows[0:150:2])
        np.testing.assert_array_equal(joined.motion.values[100:], rows[450:600:2])
        with self.assertRaises(mm.MotionManifoldError) as refused:
            self.client.join_clips(a, b, transition_seconds=5.0)
        self.assertEqual(refused.exception.field, "transition_seconds")

    def test_models_are_listed_described_activated_and_deleted_with_the_token(self):
        grpc = self.grpc
        os.symlink(os.path.abspath(os.path.join(ARGS.models, "h36m-dkgm-cpu")),
                   os.path.join(self.server.store, "spare-cpu"))
        models = {m.name: m for m in self.client.list_models()}
        self.assertTrue(models[DEFAULT_MODEL].active)
        self.assertIn("spare-cpu", models)
        info = self.client.describe_model()
        self.assertEqual((info.name, info.latent, info.frames, info.columns), (DEFAULT_MODEL, 64, 150, 99))
        skeleton = self.client.skeleton()
        self.assertEqual((skeleton.name, skeleton.joint_count, skeleton.columns), ("h36m-32", 32, 99))
        self.assert_refused(lambda: self.client.describe_model("nope"), grpc.StatusCode.NOT_FOUND, "model")
        self.assert_refused(lambda: self.anonymous.activate_model(DEFAULT_MODEL), grpc.StatusCode.UNAUTHENTICATED,
                            "authorization")
        wrong = self.mm.Client(self.server.grpc_address, token="wrong")
        self.assert_refused(lambda: wrong.activate_model(DEFAULT_MODEL), grpc.StatusCode.UNAUTHENTICATED,
                            "authorization")
        wrong.close()
        self.assertTrue(self.client.activate_model(DEFAULT_MODEL).active)
        self.assert_refused(lambda: self.client.delete_model(DEFAULT_MODEL), grpc.StatusCode.FAILED_PRECONDITION,
                            "model")
        self.assert_refused(lambda: self.anonymous.delete_model("spare-cpu"), grpc.StatusCode.UNAUTHENTICATED,
                            "authorization")
        self.assertEqual(self.client.delete_model("spare-cpu").name, "spare-cpu")
        self.assertNotIn("spare-cpu", [m.name for m in self.client.list_models()])
        self.assertTrue(os.path.isdir(os.path.join(ARGS.models, "h36m-dkgm-cpu")))  # a link's target is kept

    # --- clips of the data root, and BVH against the server's own conversion

    def test_clips_are_listed_read_uploaded_and_deleted_with_the_token(self):
        np, grpc = self.np, self.grpc
        self.assert_refused(self.anonymous.list_clips, grpc.StatusCode.UNAUTHENTICATED, "authorization")
        listed = self.client.list_clips()
        self.assertEqual([(c.path, c.format) for c in listed.clips],
                         [("h36m/S1/walking_1.txt", "h36m-text"), ("h36m/S5/walking_1.txt", "h36m-text")])
        window = self.client.read_clip("h36m/S5/walking_1.txt", start=100)
        self.assertEqual((window.start, window.file_frame_rate, window.motion.values.shape), (100, 50.0, (150, 99)))
        np.testing.assert_allclose(window.motion.values, self.mm.read_text(self.walk).values[100:400:2], atol=1e-6)
        self.assert_refused(lambda: self.client.read_clip("h36m/S5/walking_1.txt", start=window.last_start + 1),
                            grpc.StatusCode.INVALID_ARGUMENT, "start")
        self.assert_refused(lambda: self.client.read_clip("../outside.txt"), grpc.StatusCode.INVALID_ARGUMENT, "path")
        whole = self.client.read_clip("h36m/S5/walking_1.txt", whole=True)
        self.assertEqual((whole.file_frames, whole.motion.frame_rate), (3000, 50.0))
        np.testing.assert_allclose(whole.motion.values, self.mm.read_text(self.walk).values, atol=1e-6)

        # A BVH this package writes, uploaded: the server reads it as this package does.
        bvh = os.path.join(self.scratch, "walk.bvh")
        self.client.write_motion(self.client.read_take(self.walk), bvh)  # the whole take at 50 Hz
        uploaded = self.client.upload_clip("mine/walk.bvh", bvh)
        self.assertEqual((uploaded.path, uploaded.format, uploaded.uploaded), ("mine/walk.bvh", "bvh", True))
        self.assert_refused(lambda: self.client.upload_clip("mine/walk.bvh", bvh), grpc.StatusCode.FAILED_PRECONDITION,
                            "path")
        served = self.client.read_clip("mine/walk.bvh", start=40)
        ours = self.client.read_motion(bvh, start=20)  # 25 Hz frames: the file's row 40
        self.assertEqual(served.file_frame_rate, 50.0)
        np.testing.assert_allclose(served.motion.values[:, 3:], ours.values[:, 3:], atol=2e-6)
        np.testing.assert_allclose(served.motion.values[1:, :3], ours.values[1:, :3], atol=1e-3)  # root: mm
        self.assert_refused(lambda: self.anonymous.delete_clip("mine/walk.bvh"), grpc.StatusCode.UNAUTHENTICATED,
                            "authorization")
        self.assertEqual(self.client.delete_clip("mine/walk.bvh").path, "mine/walk.bvh")
        self.assert_refused(lambda: self.client.delete_clip("h36m/S5/walking_1.txt"),
                            grpc.StatusCode.FAILED_PRECONDITION, "path")

    def test_bvh_is_read_and_written_as_the_server_converts_it(self):
        np, mm = self.np, self.mm
        code = np.linspace(-1, 1, 64, dtype=np.float32)
        motion = self.client.decode(code).motions[0]
        request = urllib.request.Request(self.server.rest_url + "/v1/decode",
                                         data=json.dumps({"codes": [code.tolist()]}).encode(),
                                         headers={"Content-Type": "application/json", "Accept": "application/x-bvh"})
        with urllib.request.urlopen(request, timeout=120) as reply:
            server_bvh = reply.read().decode()
        ours = mm.bvh_text(mm.motion_to_bvh(self.client.skeleton(), motion))
        hierarchy = server_bvh.split("MOTION")[0]
        self.assertEqual(ours.split("MOTION")[0], hierarchy)  # joints, End Sites, channels, offsets: the same text
        server_file, our_file = mm.parse_bvh(server_bvh, "REST"), mm.parse_bvh(ours, "ours")
        self.assertEqual((our_file.values.shape, our_file.frame_rate), (server_file.values.shape, 25.0))
        np.testing.assert_allclose(our_file.values, server_file.values, atol=2e-5)  # degrees and mm, 6 decimals
        read_back = mm.motion_from_bvh(self.client.skeleton(), server_file, "REST")
        np.testing.assert_allclose(read_back.values[:, 3:], motion.values[:, 3:], atol=1e-5)

    def test_bvh_of_a_rig_of_ones_own_in_cm_keeps_every_joints_world_position(self):
        np, mm = self.np, self.mm
        archive = os.path.join(ARGS.shared_dir, "data", "cmu-dance-bvh.tar.xz")
        member = "cmu-dance-bvh/martial/08.bvh"
        subprocess.run(["tar", "-xJf", archive, "-C", self.scratch, "--occurrence=1", member], check=True)
        with open(os.path.join(self.scratch, member), "rb") as f:
            original = mm.parse_bvh(f.read(), member)
        rig = mm.Skeleton.from_bvh(original, "cmu-dance", millimetres_per_unit=10)
        motion = mm.motion_from_bvh(rig, original, member)
        self.assertEqual((motion.frames, motion.columns), (original.values.shape[0], rig.columns))
        self.assertEqual(motion.frame_rate, original.frame_rate)
        written = mm.parse_bvh(mm.bvh_text(mm.motion_to_bvh(rig, motion)), "written")
        self.assertEqual([(j.name, j.parent, j.channels, j.end_site) for j in written.joints],
                         [(j.name, j.parent, j.channels, j.end_site) for j in original.joints])
        for frame in range(0, original.values.shape[0], 97):
            np.testing.assert_allclose(bvh_world_positions(written, frame), bvh_world_positions(original, frame),
                                       atol=1e-4, err_msg=f"frame {frame}")  # cm; measured 1.5e-5 (float32 angles)

    def test_a_malformed_or_foreign_bvh_is_refused_naming_the_file_and_line(self):
        path = os.path.join(self.scratch, "broken.bvh")
        with open(path, "w", encoding="utf-8") as f:
            f.write("HIERARCHY\nROOT Hips\n{\n\tOFFSET 0 0 0\n\tCHANNELS 9 Xposition\n}\nMOTION\n")
        with self.assertRaisesRegex(self.mm.BvhError, r"broken\.bvh:5: channel count 9, expected 0 to 6"):
            self.client.read_motion(path)
        with open(path, "w", encoding="utf-8") as f:
            f.write("HIERARCHY\nROOT Pelvis\n{\n\tOFFSET 0 0 0\n\tCHANNELS 3 Xrotation Yrotation Zrotation\n"
                    "\tEnd Site\n\t{\n\t\tOFFSET 0 1 0\n\t}\n}\nMOTION\nFrames: 1\nFrame Time: 0.04\n0 0 0\n")
        with self.assertRaisesRegex(self.mm.BvhError, r"not the H3\.6M skeleton .*missing joints: Hips"):
            self.client.read_take(path)

    # --- jobs

    def test_a_job_is_submitted_watched_cancelled_and_deleted(self):
        grpc = self.grpc
        self.assert_refused(lambda: self.anonymous.submit_job("h36m"), grpc.StatusCode.UNAUTHENTICATED,
                            "authorization")
        job = self.client.submit_job("h36m", iterations=1000000, hidden=16, batch=4, seed=1)
        self.assertIn(job.state, ("queued", "running"))
        self.assertEqual(job.spec.variant, "DKGM")
        self.assertEqual(self.client.get_job(job.id).id, job.id)
        self.assertIn(job.id, [j.id for j in self.client.list_jobs()])
        watch = self.client.watch_job(job.id, timeout=300)
        first = next(watch)
        threading.Timer(0.5, lambda: self.client.cancel_job(job.id)).start()
        states = [first.state] + [record.state for record in watch]
        self.assertEqual(states[-1], "cancelled", states)
        self.assert_refused(lambda: self.client.get_job("no-such-job"), grpc.StatusCode.NOT_FOUND, "id")
        for _ in range(300):  # deleted once its run has stopped
            try:
                self.assertEqual(self.client.delete_job(job.id).state, "cancelled")
                break
            except self.mm.MotionManifoldError as error:
                self.assertEqual(error.code, grpc.StatusCode.FAILED_PRECONDITION, error.message)
                time.sleep(0.2)
        self.assert_refused(lambda: self.client.get_job(job.id), grpc.StatusCode.NOT_FOUND, "id")

    # --- takes

    def test_a_take_streamed_from_its_file_gives_a_code_every_hop(self):
        np, mm = self.np, self.mm
        take = mm.read_text(self.walk)
        track = self.client.encode_take(self.walk)  # streamed as the file is read, 50 Hz
        self.assertEqual((track.frames, track.frame_rate, track.hop_seconds, track.window_seconds),
                         (take.frames, 50.0, 3.0, 6.0))
        windows = int(np.ceil((take.seconds - 6) / 3)) + 1  # every 3 s, the last aligned to the end
        self.assertEqual(track.codes.shape, (windows, 64))
        np.testing.assert_array_equal(track.start_seconds[:-1], np.arange(windows - 1) * 3.0)
        # Its first window is the file's first 6 s: the code Encode gives them.
        np.testing.assert_allclose(track.codes[0], self.client.encode(mm.Motion(take.values[:300], 50)).codes[0],
                                   atol=1e-5)
        # (A whole track decoded at 120 Hz: the README's example, below.)

    def test_a_take_from_an_array_comes_back_at_its_rate_and_length_with_its_root_and_errors(self):
        np, mm = self.np, self.mm
        take = mm.Motion(mm.read_text(self.walk).values[:600], 50)  # the file's first 12 s, as an array
        result = self.client.reconstruct_take(take)
        self.assertEqual((result.motion.frames, result.motion.columns, result.motion.frame_rate), (600, 99, 50.0))
        self.assertEqual(result.input_frames, 600)
        np.testing.assert_allclose(result.motion.values[:, :3], take.values[:, :3], atol=1e-5)  # the root copied
        self.assertEqual(result.error_mm.shape, (600,))
        self.assertAlmostEqual(float(result.error_mm.mean()), result.mean_error_mm, delta=0.01)
        self.assertAlmostEqual(float(result.error_mm.max()), result.max_error_mm, delta=0.01)
        np.testing.assert_array_equal(result.track.start_seconds, [0.0, 3.0, 6.0])

        # An edited track: its first two windows (0 to 9 s) as one motion at 120 Hz.
        first = mm.CodeTrack(result.track.codes[:2], result.track.start_seconds[:2], result.track.start_frames[:2])
        motion = self.client.decode_track(first, frame_rate=120)
        # From 0 to the last window's last frame, 3 + 5.96 s.
        self.assertEqual((motion.motion.frame_rate, motion.motion.frames), (120.0, int((3 + 149 / 25) * 120) + 1))
        self.assertEqual(motion.motion.values.shape[1], 99)
        self.assertEqual(motion.error_mm.size, 0)

        # The same frames as a BVH file at 50 Hz: nearly the same codes.
        bvh = os.path.join(self.scratch, "walk_take.bvh")
        self.client.write_motion(take, bvh)
        umask = os.umask(0)
        os.umask(umask)
        self.assertEqual(os.stat(bvh).st_mode & 0o777, 0o666 & ~umask)  # as open() makes files, not 0600
        from_bvh = self.client.encode_take(bvh)
        self.assertEqual((from_bvh.frames, from_bvh.frame_rate), (600, 50.0))
        np.testing.assert_allclose(from_bvh.codes, result.track.codes, atol=1e-3)

    def test_denoise_take_fills_missing_values_and_keeps_the_observed(self):
        np, mm = self.np, self.mm
        take = mm.read_text(self.walk)
        values = take.values[:400].copy()  # 8 s at 50 Hz
        values[100:125, 3:30] = np.nan  # 0.5 s of nine joints missing
        result = self.client.denoise_take(mm.Motion(values, 50), keep_observed=True, hop=2)
        self.assertEqual(result.motion.values.shape, (400, 99))
        self.assertFalse(np.any(np.isnan(result.motion.values)))
        observed = ~np.isnan(values)
        np.testing.assert_allclose(result.motion.values[observed], values[observed], atol=1e-6)

    def test_denoise_take_passes_gap_fill_and_counts_the_fitted_gaps(self):
        # 20 s of walking with every joint missing for 2 s: slerp fills the
        # gap otherwise than the default, a code fitted to the gap's window,
        # which the result counts; slerp fits none. A method the server does
        # not know is refused naming gap_fill.
        np, mm, grpc = self.np, self.mm, self.grpc
        values = mm.read_text(self.walk).values[:1000].copy()
        values[500:600, 3:] = np.nan
        take = mm.Motion(values, 50)
        fitted = self.client.denoise_take(take, keep_observed=True)
        slerped = self.client.denoise_take(take, keep_observed=True, gap_fill="slerp")
        self.assertGreater(np.max(np.abs(fitted.motion.values[500:600] - slerped.motion.values[500:600])), 0.05)
        self.assertEqual((fitted.gap_windows_fitted, fitted.gaps_fitted, fitted.gaps_over_fit_limit), (1, 1, 0))
        self.assertEqual((slerped.gap_windows_fitted, slerped.gaps_fitted, slerped.gaps_over_fit_limit), (0, 0, 0))
        self.assert_refused(lambda: self.client.denoise_take(take, keep_observed=True, gap_fill="spline"),
                            grpc.StatusCode.INVALID_ARGUMENT, "gap_fill")

    # --- refusals carry their field

    def test_refusals_raise_one_exception_carrying_status_and_field(self):
        np, mm, grpc = self.np, self.mm, self.grpc
        invalid = grpc.StatusCode.INVALID_ARGUMENT
        self.assert_refused(lambda: self.client.decode(np.zeros(63)), invalid, "codes[0]")
        clip = self.client.read_motion(self.walk)
        self.assert_refused(lambda: self.client.encode([clip, mm.Motion(clip.values[:100], 25)]), invalid,
                            "motions[1].frames")
        self.assert_refused(lambda: self.client.encode(mm.Motion(clip.values, 30)), invalid, "motions[0].frame_rate")
        self.assert_refused(lambda: self.client.sample(decoder="nope"), invalid, "decoder")
        self.assert_refused(lambda: self.client.sample(model="nope"), grpc.StatusCode.NOT_FOUND, "model")
        too_large = mm.Motion(np.zeros((MAX_MESSAGE_BYTES // 4 // 99 + 10, 99)), 25)  # refused by gRPC itself
        self.assert_refused(lambda: self.client.encode(too_large), grpc.StatusCode.RESOURCE_EXHAUSTED, "")
        take = mm.read_text(self.walk)
        self.assert_refused(lambda: self.client.reconstruct_take(mm.Motion(take.values[:600], 5000)), invalid,
                            "frame_rate")
        self.assert_refused(lambda: self.client.encode_take(mm.Motion(take.values[:200], 50)), invalid, "take")
        self.assert_refused(lambda: self.client.reconstruct_take(take, hop=7), invalid, "hop_seconds")
        # A file broken midway: its own error, not the call's cancellation.
        broken = os.path.join(self.scratch, "broken.txt")
        with open(self.walk, encoding="utf-8") as source, open(broken, "w", encoding="utf-8") as out:
            lines = source.readlines()[:2500]
            lines[2300] = "0,1,2\n"
            out.writelines(lines)
        with self.assertRaisesRegex(mm.MotionTextError, r"broken\.txt:2301: 3 values, expected 99"):
            self.client.reconstruct_take(broken)
        self.assertEqual(self.client.encode(clip).codes.shape, (1, 64))  # still serving
        with self.assertRaises(TypeError):
            self.client.encode(clip.values)  # an array without its rate

    # --- the README's example

    def test_the_readme_example_runs_and_prints_what_the_readme_shows(self):
        with open(os.path.join(ARGS.package, "README.md"), encoding="utf-8") as f:
            readme = f.read()
        example = re.search(r"## Example.*?```python\n(.*?)```.*?```\n(.*?)```", readme, re.S)
        self.assertIsNotNone(example, "client/python/README.md has no example with its output")
        code, shown = example.group(1), example.group(2)
        self.assertIn('"localhost:50051"', code)
        os.makedirs(os.path.join(self.scratch, "data", "h3.6m"))
        os.symlink(h36m_dataset_dir(), os.path.join(self.scratch, "data", "h3.6m", "dataset"))  # the example's paths
        run = subprocess.run([sys.executable, "-c", code.replace("localhost:50051", self.server.grpc_address)],
                             cwd=self.scratch, capture_output=True, text=True, timeout=300, check=False)
        self.assertEqual(run.returncode, 0, run.stderr)
        printed, expected = run.stdout.splitlines(), shown.strip().splitlines()
        self.assertEqual(len(printed), len(expected), run.stdout)
        number = r"-?\d+\.?\d*"
        for got, want in zip(printed, expected):
            # The words and shapes as shown; measured values within 0.2 (a model's arithmetic may round apart).
            self.assertEqual(re.sub(number, "#", got), re.sub(number, "#", want), run.stdout)
            for a, b in zip(re.findall(number, got), re.findall(number, want)):
                self.assertAlmostEqual(float(a), float(b), delta=0.2, msg=f"{got!r} against {want!r}")
        self.assertTrue(os.path.exists(os.path.join(self.scratch, "walk_120.bvh")))

    # --- TLS

    def test_tls_serves_a_client_that_trusts_its_certificate(self):
        tls = SERVERS["tls"]
        with self.mm.Client(tls.grpc_address, root_certificates=SERVERS["cert"]) as secure:
            self.assertEqual([m.name for m in secure.list_models()], ["h36m-dkgm-cpu"])
            self.assertEqual(secure.describe_model().layout, "h36m-expmap-99")
        with self.mm.Client(tls.grpc_address, timeout=10) as plain:
            self.assert_refused(plain.list_models, self.grpc.StatusCode.UNAVAILABLE, "")


def main():
    global ARGS  # pylint: disable=global-statement
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--server", required=True, help="the motion-manifold-server binary")
    parser.add_argument("--package", required=True, help="the package's folder (client/python)")
    parser.add_argument("--proto-dir", required=True, help="the folder holding motionmanifold/v1/manifold.proto")
    parser.add_argument("--models", required=True, help="the folder of the shipped models")
    parser.add_argument("--shared-dir", required=True, help="the shared folder holding data/cmu-dance-bvh.tar.xz")
    parser.add_argument("--installed-in", help="(internal) the virtual environment this run imports the package from")
    ARGS, rest = parser.parse_known_args()
    if not os.path.exists(os.path.join(h36m_dataset_dir(), "S5", "walking_1.txt")):
        if os.environ.get("MM_ALLOW_MISSING_H36M") == "1":
            print("H3.6M not found: skipped", file=sys.stderr)
            sys.exit(SKIPPED)
        raise SystemExit(f"H3.6M not found under {h36m_dataset_dir()} (run scripts/extract-h36m.sh, or set "
                         "MM_ALLOW_MISSING_H36M=1)")
    if ARGS.installed_in is None:
        sys.exit(install_and_rerun())
    unittest.main(argv=[sys.argv[0]] + rest, verbosity=2)


if __name__ == "__main__":
    main()
