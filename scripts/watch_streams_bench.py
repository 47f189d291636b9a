#!/usr/bin/python3
"""Latency of calls while job watch streams are open, on the real server
(docs/PERFORMANCE.md, "Calls while job watch streams are open").

  scripts/watch_streams_bench.py SERVER REST_STREAMS GRPC_STREAMS [SERVER OPTIONS...]

Starts SERVER on loopback with a state folder and a two-file H3.6M data root
(the files of $MM_DATA_DIR, default data/), submits two long training jobs so
that the second stays queued, asks for REST_STREAMS event streams of it (from
127.0.0.1, .2, ... eight each, the default per-client cap) and GRPC_STREAMS
WatchJob streams (from 127.0.0.1), then times /healthz, /v1/models and gRPC
ListModels 200 times each, one at a time, each on a new connection (5 s
timeout). Needs Debian's python3-grpcio and python3-grpc-tools (/usr/bin/python3)."""
import json
import os
import shutil
import socket
import statistics
import subprocess
import sys
import tempfile
import time
import urllib.request

import grpc

source = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
stubs = tempfile.mkdtemp(prefix="mm-watch-bench-stubs-")
subprocess.run([sys.executable, "-m", "grpc_tools.protoc", "-I", os.path.join(source, "proto"), "--python_out", stubs,
                "--grpc_python_out", stubs, os.path.join(source, "proto/motionmanifold/v1/manifold.proto")], check=True)
sys.path.insert(0, stubs)
from motionmanifold.v1 import manifold_pb2, manifold_pb2_grpc  # noqa: E402

server, n_rest, n_grpc = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
extra = sys.argv[4:]
dataset = os.environ.get("MM_DATA_DIR", os.path.join(source, "data"))
if os.path.isdir(os.path.join(dataset, "h3.6m", "dataset")):
    dataset = os.path.join(dataset, "h3.6m", "dataset")
scratch = tempfile.mkdtemp(prefix="mm-watch-bench-")
data = os.path.join(scratch, "data")
for s in ("S1", "S5"):
    os.makedirs(os.path.join(data, "h36m", s))
    os.symlink(os.path.join(dataset, s, "walking_1.txt"), os.path.join(data, "h36m", s, "walking_1.txt"))
ready = os.path.join(scratch, "ready.json")
log = open(os.path.join(scratch, "server.log"), "w")
proc = subprocess.Popen([server, "--grpc-port", "0", "--rest-port", "0", "--address", "127.0.0.1", "--ready-file", ready,
                         "--model-store", os.path.join(source, "models"), "--state-dir", os.path.join(scratch, "state"),
                         "--data-root", data] + extra, stdout=log, stderr=log)
try:
    while not os.path.exists(ready):
        time.sleep(0.1)
    time.sleep(0.2)
    ports = json.load(open(ready))
    rest, grpc_port = ports["rest_port"], ports["grpc_port"]
    spec = json.dumps({"dataset": "h36m", "variant": "D", "iterations": 1000000, "hidden": 16, "batch": 4}).encode()
    for _ in range(2):
        req = urllib.request.Request(f"http://127.0.0.1:{rest}/v1/jobs", data=spec, headers={"Content-Type": "application/json"})
        job = json.load(urllib.request.urlopen(req, timeout=60))
    jid = job["id"]
    socks, statuses = [], {}
    for i in range(n_rest):
        s = socket.socket()
        s.bind((f"127.0.0.{1 + i // 8}", 0))
        s.settimeout(5)
        s.connect(("127.0.0.1", rest))
        s.sendall(f"GET /v1/jobs/{jid}/events HTTP/1.1\r\nHost: x\r\n\r\n".encode())
        try:
            head = s.recv(4096).decode(errors="replace")
            code = head.split(" ")[1]
        except socket.timeout:
            code = "no answer in 5 s"
        statuses[code] = statuses.get(code, 0) + 1
        socks.append(s)
        if code == "no answer in 5 s":
            break
    channel = grpc.insecure_channel(f"127.0.0.1:{grpc_port}")
    stub = manifold_pb2_grpc.MotionManifoldStub(channel)
    watches, gstatuses = [], {}
    for i in range(n_grpc):
        call = stub.WatchJob(manifold_pb2.WatchJobRequest(id=jid), timeout=600)
        try:
            next(call)
            gstatuses["OK"] = gstatuses.get("OK", 0) + 1
            watches.append(call)
        except grpc.RpcError as e:
            key = f"{e.code().name}: {e.details()[:60]}"
            gstatuses[key] = gstatuses.get(key, 0) + 1
    threads = int([l for l in open(f"/proc/{proc.pid}/status") if l.startswith("Threads:")][0].split()[1])
    rss = int([l for l in open(f"/proc/{proc.pid}/status") if l.startswith("VmRSS:")][0].split()[1]) / 1024
    print(f"REST streams asked {n_rest}: {statuses}; gRPC streams asked {n_grpc}: {gstatuses}; server threads {threads}, RSS {rss:.0f} MiB")

    def timed(fn, n=200):
        times, failures = [], 0
        for _ in range(n):
            t0 = time.perf_counter()
            try:
                fn()
                times.append((time.perf_counter() - t0) * 1000)
            except Exception as e:  # noqa: BLE001 (a timeout, a refused call: counted, not raised)
                failures += 1
                if failures == 1:
                    print("  first failure:", str(e)[:120])
                if failures >= 3:
                    break
        if not times:
            return f"no answer ({failures} failures)"
        times.sort()
        return f"p50 {statistics.median(times):.2f} ms, p99 {times[int(0.99 * (len(times) - 1))]:.2f} ms, max {times[-1]:.2f} ms, {failures} failed of {len(times) + failures}"

    def get(path):
        with urllib.request.urlopen(f"http://127.0.0.1:{rest}{path}", timeout=5) as r:
            r.read()
            assert r.status == 200
    print("  GET /healthz:", timed(lambda: get("/healthz")))
    print("  GET /v1/models:", timed(lambda: get("/v1/models")))
    print("  gRPC ListModels:", timed(lambda: stub.ListModels(manifold_pb2.ListModelsRequest(), timeout=5)))
    for w in watches:
        w.cancel()
    for s in socks:
        s.close()
finally:
    proc.kill()
    proc.wait()
    shutil.rmtree(scratch, ignore_errors=True)
    shutil.rmtree(stubs, ignore_errors=True)
