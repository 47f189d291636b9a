#!/usr/bin/env python3
"""Writes the fuzz targets' seed corpora, tests/fuzz/corpus/<target>/.

Every seed is made here by hand: zero motions and codes, the H3.6M skeleton's
hierarchy as the shipped model describes it (the BVH writer's own output for
models/h36m-dkgm-cpu, motion replaced by two frames of zeros), a two-joint
BVH, three rows of text. No recorded motion is in them.

  python3 tests/fuzz/make_seeds.py build/model/tool/motion-manifold

The tool (any build) writes the hierarchy; protoc encodes the gRPC messages.
"""
import json
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
PROTO = "motionmanifold/v1/manifold.proto"

FRAMES, COLUMNS = 150, 99
LAYOUT = "h36m-expmap-99"
CODE = [round(0.1 * ((i % 7) - 3), 1) for i in range(64)]
TWO_JOINT_BVH = """HIERARCHY
ROOT hip
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation
  JOINT knee
  {
    OFFSET 0 -40 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0 -40 0
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.0083333
0 90 0 0 0 0 0 10 0
1 90 0 0 0 0 0 20 0
"""


def h36m_bvh(tool):
    """The model's hierarchy with two frames 5.96 s apart: 150 frames at 25 Hz once imported."""
    with tempfile.TemporaryDirectory() as scratch:
        code = os.path.join(scratch, "code.json")
        out = os.path.join(scratch, "zero.bvh")
        with open(code, "w") as f:
            json.dump({"code": [0.0] * 64}, f)
        subprocess.run([tool, "decode", "--model", os.path.join(ROOT, "models", "h36m-dkgm-cpu"), "--code", code,
                        "--out", out], check=True, capture_output=True)
        text = open(out).read()
    hierarchy = text[:text.index("MOTION")]
    channels = len(text.split("Frame Time:")[1].splitlines()[1].split())
    zeros = " ".join(["0"] * channels)
    return hierarchy + "MOTION\nFrames: 2\nFrame Time: 5.96\n" + zeros + "\n" + zeros + "\n"


def motion_json(frames=FRAMES, columns=COLUMNS, rate=25):
    return {"frames": frames, "columns": columns, "frame_rate": rate, "layout": LAYOUT,
            "values": [0] * (frames * columns)}


def text_rows(rows):
    return "".join(",".join(["0"] * COLUMNS) + "\n" for _ in range(rows))


def rest_seeds(bvh):
    def request(line, body=None, headers=()):
        head = line + "\n" + "".join(h + "\n" for h in headers) + "\n"
        if body is None:
            return head
        return head + (body if isinstance(body, str) else json.dumps(body, separators=(",", ":")))

    small = motion_json(frames=2)
    job = "0123456789ab"
    return {
        "encode_json": request("POST /v1/encode", {"motions": [motion_json()]}, ["Content-Type: application/json"]),
        "encode_small_json": request("POST /v1/encode", {"model": "h36m-dkgm-cpu", "motions": [small]}),
        "encode_bvh": request("POST /v1/encode?model=h36m-dkgm-cpu", bvh, ["Content-Type: application/x-bvh"]),
        "denoise_bvh": request("POST /v1/denoise", bvh, ["Content-Type: application/x-bvh", "Accept: application/x-bvh"]),
        "denoise_json": request("POST /v1/denoise", {"motions": [small], "means_are_missing": True,
                                                     "keep_observed": True, "iterations": 2, "decoder": "velocity"}),
        "decode": request("POST /v1/decode", {"codes": [CODE], "decoder": "velocity"}),
        "decode_bvh": request("POST /v1/decode", {"codes": [CODE]}, ["Accept: application/x-bvh"]),
        "sample": request("POST /v1/sample", {"count": 2, "seed": "18446744073709551615", "decoder": "rotation"}),
        "interpolate": request("POST /v1/interpolate", {"from": {"code": CODE}, "to": {"code": [0] * 64}, "steps": 3,
                                                        "method": "spherical"}),
        "interpolate_motion": request("POST /v1/interpolate", {"from": {"motion": small}, "to": {"code": CODE}}),
        "analogy": request("POST /v1/analogy", {"a": {"code": CODE}, "b": {"code": [0] * 64},
                                                "c": {"code": ["NaN"] + [0] * 63}}),
        "models": request("GET /v1/models"),
        "describe": request("GET /v1/models/h36m-dkgm-cpu"),
        "activate": request("POST /v1/models/h36m-dkgm-cpu:activate", {}, ["Authorization: Bearer abc"]),
        "clips": request("GET /v1/clips"),
        "window_text": request("GET /v1/clips/window?path=tree%2FS1%2Fwalking_1.txt&start=5"),
        "window_bvh": request("GET /v1/clips/window?path=cmu/dance_a.bvh&start=3&model=h36m-dkgm-cpu"),
        "whole_text": request("GET /v1/clips/motion?path=tree%2FS1%2Fwalking_1.txt"),
        "whole_bvh": request("GET /v1/clips/motion?path=cmu/dance_a.bvh&model=h36m-dkgm-cpu"),
        "upload_text": request("POST /v1/clips:upload?path=mine/S1/walking_1.txt", text_rows(3)),
        "upload_bvh": request("POST /v1/clips:upload?path=mine/a.bvh", TWO_JOINT_BVH),
        "submit": request("POST /v1/jobs", {"dataset": "cmu", "variant": "DKGM", "iterations": 10, "hidden": 16,
                                            "batch": 2, "seed": 1, "model_name": "mine",
                                            "config": {"variant": "DK", "model": {"hidden": 16}, "batch": 4}}),
        "submit_tree": request("POST /v1/jobs", {"dataset": "tree", "iterations": "5"}),
        "jobs": request("GET /v1/jobs"),
        "job": request("GET /v1/jobs/" + job),
        "cancel": request("POST /v1/jobs/" + job + ":cancel"),
        "events": request("GET /v1/jobs/" + job + "/events"),
        "health": request("GET /healthz"),
        "ready": request("GET /readyz"),
        "metrics": request("GET /metrics"),
    }


def grpc_seeds(bvh):
    def motion(frames):
        return ("{ frames: %d columns: %d frame_rate: 25 layout: \"%s\" values: [%s] }"
                % (frames, COLUMNS, LAYOUT, ",".join(["0"] * (frames * COLUMNS))))

    code = "{ values: [%s] }" % ",".join(str(v) for v in CODE)
    return {
        "encode": ("Encode", "EncodeRequest", "motions " + motion(FRAMES)),
        "encode_small": ("Encode", "EncodeRequest", "model: \"h36m-dkgm-cpu\" motions " + motion(2)),
        "decode": ("Decode", "DecodeRequest", "codes " + code + " decoder: \"velocity\""),
        "sample": ("Sample", "SampleRequest", "count: 2 seed: 18446744073709551615"),
        "interpolate": ("Interpolate", "InterpolateRequest",
                        "from { code " + code + " } to { motion " + motion(2) + " } steps: 3 method: \"spherical\""),
        "analogy": ("Analogy", "AnalogyRequest", "a { code " + code + " } b { code " + code + " } c { code " + code + " }"),
        "denoise": ("Denoise", "DenoiseRequest",
                    "motions " + motion(2) + " zeros_are_missing: true keep_observed: true iterations: 2"),
        "models": ("ListModels", "ListModelsRequest", ""),
        "describe": ("DescribeModel", "DescribeModelRequest", "model: \"h36m-dkgm-cpu\""),
        "activate": ("ActivateModel", "ActivateModelRequest", "model: \"h36m-dkgm-cpu\""),
        "clips": ("ListClips", "ListClipsRequest", ""),
        "window_text": ("ReadClip", "ReadClipRequest", "path: \"tree/S1/walking_1.txt\" start: 5"),
        "window_bvh": ("ReadClip", "ReadClipRequest", "model: \"h36m-dkgm-cpu\" path: \"cmu/dance_a.bvh\" start: 3"),
        "whole_text": ("ReadClip", "ReadClipRequest", "path: \"tree/S1/walking_1.txt\" whole: true"),
        "whole_bvh": ("ReadClip", "ReadClipRequest", "model: \"h36m-dkgm-cpu\" path: \"cmu/dance_a.bvh\" whole: true"),
        "upload_text": ("UploadClip", "UploadClipRequest",
                        "path: \"mine/S1/walking_1.txt\" content: \"%s\"" % text_rows(3).replace("\n", "\\n")),
        "upload_bvh": ("UploadClip", "UploadClipRequest",
                       "path: \"mine/a.bvh\" content: \"%s\"" % TWO_JOINT_BVH.replace("\n", "\\n")),
        "submit": ("SubmitJob", "SubmitJobRequest",
                   "spec { dataset: \"cmu\" variant: \"DKGM\" iterations: 10 hidden: 16 batch: 2 seed: 1 "
                   "model_name: \"mine\" config_json: \"{\\\"variant\\\": \\\"DK\\\", \\\"batch\\\": 4}\" }"),
        "job": ("GetJob", "GetJobRequest", "id: \"0123456789ab\""),
        "jobs": ("ListJobs", "ListJobsRequest", ""),
        "cancel": ("CancelJob", "CancelJobRequest", "id: \"0123456789ab\""),
        "watch": ("WatchJob", "WatchJobRequest", "id: \"0123456789ab\""),
    }


def write(folder, name, content):
    os.makedirs(folder, exist_ok=True)
    with open(os.path.join(folder, name), "wb") as f:
        f.write(content if isinstance(content, bytes) else content.encode())


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    bvh = h36m_bvh(sys.argv[1])
    corpus = os.path.join(HERE, "corpus")
    for name, content in rest_seeds(bvh).items():
        write(os.path.join(corpus, "rest_request"), name, content)
    for name, (rpc, message, text) in grpc_seeds(bvh).items():
        encoded = subprocess.run(["protoc", "-I", os.path.join(ROOT, "proto"), "--encode=motionmanifold.v1." + message,
                                  PROTO], input=text.encode(), check=True, capture_output=True).stdout
        write(os.path.join(corpus, "grpc_request"), name, rpc.encode() + b"\n" + encoded)


if __name__ == "__main__":
    main()
