#!/usr/bin/env python3
"""README.md's examples run as written, against a real server started as
scripts/serve.sh starts it (its store, state and data folders, no token), so
that they cannot drift from the service again.

Every ```sh block runs, in document order, in one bash session (a block's
variables and files are the next one's, as in a reader's shell) with
`set -eo pipefail`; every ```python block runs with /usr/bin/python3. A
block is left out only by a rule of SKIPPED below, which says why (it builds,
installs, deploys or trains for minutes); those are still parsed by
`bash -n`. Three things differ from a reader's shell, all of them said here:
- the server listens on free ports, not 8080 and 50051, and `localhost:8080`
  and `localhost:50051` in a block are read as those ports (the client gets
  them through MM_SERVER and MM_REST_URL);
- `curl` is `curl --fail-with-body`, so a refusal (HTTP 400 and above) fails
  the block instead of printing an error a reader would have to notice;
- the checkout is a scratch folder linking the real build/, scripts/,
  models/, proto/ and client/, its data/ holding H3.6M's S5 (the files the
  blocks read), so that what the blocks write (walk.json,
  data/cmu-dance-bvh, runs/dances, ...) is thrown away.

    readme_examples_test.py --source DIR --build DIR --data DIR --shared DIR
Exit 0 when every block ran; 1 naming the block (its line in README.md)
and its output otherwise; 77 (skipped) without the H3.6M copy.
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
import time

# (text a block holds, why it is not run). A new block runs unless a rule
# here names it.
SKIPPED = [
    ("bash scripts/serve.sh   # main job", "the main job itself: this test starts the server as it does"),
    ("bash scripts/install-deps.sh", "installs packages and builds: the test runs on the built tree"),
    ("bash scripts/build-cuda.sh", "builds against a Python torch install"),
    ("grpcurl -plaintext", "grpcurl is not a Debian package"),
    ("scripts/build-image.sh", "builds a container image and deploys to a cluster"),
    ("--device cuda", "trains the default model on a GPU"),
    ("jobs submit", "a training job of 2000 iterations: minutes of CPU"),
    ("/v1/jobs \\", "a training job of 2000 iterations: minutes of CPU"),
]

FENCE = re.compile(r"^```(\w*)\s*$")


def blocks_of(readme):
    """(language, first line number, text, heading) of every fenced block."""
    blocks, heading, language, start, lines = [], "", None, 0, []
    for number, line in enumerate(readme.splitlines(), 1):
        if language is None:
            match = FENCE.match(line)
            if match:
                language, start, lines = match.group(1), number + 1, []
            elif line.startswith("#"):
                heading = line.lstrip("#").strip()
        elif line.startswith("```"):
            blocks.append((language, start, "\n".join(lines) + "\n", heading))
            language = None
        else:
            lines.append(line)
    return blocks


def skip_reason(text):
    for needle, reason in SKIPPED:
        if needle in text:
            return reason
    return None


def scratch_checkout(root, source, build, data, shared):
    """The layout serve.sh leaves: runs/models linking the shipped models,
    runs/state, data/ with the H3.6M copy; ../shared beside it."""
    checkout = os.path.join(root, "checkout")
    os.makedirs(os.path.join(checkout, "runs", "state"))
    os.makedirs(os.path.join(checkout, "runs", "models"))
    os.makedirs(os.path.join(checkout, "data"))
    os.symlink(os.path.abspath(shared), os.path.join(root, "shared"))
    os.symlink(os.path.abspath(build), os.path.join(checkout, "build"))
    for name in ("scripts", "models", "proto", "client", "README.md"):
        os.symlink(os.path.join(source, name), os.path.join(checkout, name))
    # The data root serves no link that leads out of it: S5's files (what the
    # blocks read) are linked in hard (copied across file systems).
    s5 = os.path.join(os.path.abspath(data), "h3.6m", "dataset", "S5")
    s5_here = os.path.join(checkout, "data", "h3.6m", "dataset", "S5")
    os.makedirs(s5_here)
    for name in sorted(os.listdir(s5)):
        try:
            os.link(os.path.join(s5, name), os.path.join(s5_here, name))
        except OSError:
            shutil.copyfile(os.path.join(s5, name), os.path.join(s5_here, name))
    for name in sorted(os.listdir(os.path.join(source, "models"))):
        if os.path.isdir(os.path.join(source, "models", name)):
            os.symlink(os.path.join("..", "..", "models", name), os.path.join(checkout, "runs", "models", name))
    return checkout


def start_server(checkout, log):
    ready = os.path.join(checkout, "runs", "ready.json")
    server = subprocess.Popen(
        ["build/server/motion-manifold-server", "--model-store", "runs/models", "--state-dir", "runs/state",
         "--data-root", "data", "--address", "127.0.0.1", "--grpc-port", "0", "--rest-port", "0",
         "--ready-file", ready,
         # One LibTorch thread, as every test server: OpenMP threads spin, and
         # a server taking both cores slows the test beside it many times over.
         "--threads", "1"],
        cwd=checkout, stdout=log, stderr=subprocess.STDOUT)
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        if server.poll() is not None:
            raise RuntimeError(f"the server exited with {server.returncode} before it was ready")
        if os.path.exists(ready):
            try:
                with open(ready) as f:
                    ports = json.load(f)
                return server, ports["grpc_port"], ports["rest_port"]
            except (ValueError, KeyError):
                pass
        time.sleep(0.1)
    server.kill()
    raise RuntimeError("the server was not ready within 120 s")


def on_ports(text, grpc_port, rest_port):
    return text.replace("localhost:8080", f"localhost:{rest_port}").replace("localhost:50051",
                                                                            f"localhost:{grpc_port}")


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--source", required=True)
    parser.add_argument("--build", required=True)
    parser.add_argument("--data", required=True)
    parser.add_argument("--shared", required=True)
    args = parser.parse_args()
    if not os.path.isdir(os.path.join(args.data, "h3.6m", "dataset", "S5")):
        print(f"no H3.6M copy under {args.data}: run scripts/extract-h36m.sh", file=sys.stderr)
        return 77 if os.environ.get("MM_ALLOW_MISSING_H36M") == "1" else 1
    with open(os.path.join(args.source, "README.md"), encoding="utf-8") as f:
        blocks = blocks_of(f.read())

    runs, failures = [], []
    for language, line, text, heading in blocks:
        if language not in ("sh", "python"):
            continue
        reason = skip_reason(text)
        if reason is None:
            runs.append((language, line, text, heading))
            continue
        if language == "sh":
            check = subprocess.run(["bash", "-n"], input=text, text=True, capture_output=True)
            if check.returncode != 0:
                failures.append(f"README.md:{line} ({heading}), not run ({reason}), is no valid bash:\n{check.stderr}")
        print(f"README.md:{line} ({heading}): not run: {reason}")
    if not runs:
        failures.append("README.md has no block to run")

    root = tempfile.mkdtemp(prefix="mm-readme-")
    server = None
    try:
        checkout = scratch_checkout(root, os.path.abspath(args.source), args.build, args.data, args.shared)
        log = open(os.path.join(root, "server.log"), "w")
        server, grpc_port, rest_port = start_server(checkout, log)
        env = dict(os.environ)
        env.pop("TOKEN", None)  # serve.sh's default: no token
        env.pop("MM_TOKEN", None)
        env["PATH"] = os.path.join(checkout, "build", "model", "tool") + os.pathsep + env["PATH"]
        env["MM_SERVER"] = f"localhost:{grpc_port}"
        env["MM_REST_URL"] = f"http://localhost:{rest_port}"
        # The sh blocks in one session, each announced so that a failure names it.
        script = ["set -eo pipefail", 'curl() { command curl --fail-with-body "$@"; }']
        for language, line, text, heading in runs:
            if language == "python":
                continue
            script.append(f"echo \">>> README.md:{line} ({heading}) at $(date +%s.%N)\" >&2")
            script.append(on_ports(text, grpc_port, rest_port))
        started = time.monotonic()
        try:
            shell = subprocess.run(["bash", "-c", "\n".join(script)], cwd=checkout, env=env, text=True,
                                   capture_output=True, timeout=900)
        except subprocess.TimeoutExpired as timeout:
            # Name the block it was in and what it had printed.
            def text_of(stream):
                return stream.decode(errors="replace") if isinstance(stream, bytes) else (stream or "")
            announced = re.findall(r">>> (README\.md:\d+ \([^)]*\))", text_of(timeout.stderr))
            print(f"sh blocks: still running after 900 s, in {announced[-1] if announced else 'the first block'}\n"
                  f"--- stderr (last 4000 characters)\n{text_of(timeout.stderr)[-4000:]}")
            raise
        ended = time.time()
        print(f"sh blocks: exit {shell.returncode} after {time.monotonic() - started:.1f} s")
        # Each block's seconds, from its announcement to the next one's.
        marks = re.findall(r">>> (README\.md:\d+ \([^)]*\)) at ([\d.]+)", shell.stderr)
        for i, (where, at) in enumerate(marks):
            until = float(marks[i + 1][1]) if i + 1 < len(marks) else ended
            print(f"  {where}: {until - float(at):.1f} s")
        if shell.returncode != 0:
            announced = re.findall(r">>> (README\.md:\d+ \([^)]*\))", shell.stderr)
            where = announced[-1] if announced else "the first block"
            failures.append(f"{where} failed with exit status {shell.returncode}\n"
                            f"--- stdout (last 4000 characters)\n{shell.stdout[-4000:]}\n"
                            f"--- stderr (last 4000 characters)\n{shell.stderr[-4000:]}")
        for language, line, text, heading in runs:
            if language != "python":
                continue
            started = time.monotonic()
            run = subprocess.run(["/usr/bin/python3", "-"], input=on_ports(text, grpc_port, rest_port), cwd=checkout,
                                 env=env, text=True, capture_output=True, timeout=300)
            print(f"README.md:{line} ({heading}): python exit {run.returncode} after "
                  f"{time.monotonic() - started:.1f} s")
            if run.returncode != 0:
                failures.append(f"README.md:{line} ({heading}) failed with exit status {run.returncode}\n"
                                f"--- stdout\n{run.stdout[-4000:]}\n--- stderr\n{run.stderr[-4000:]}")
    finally:
        if server is not None:
            server.send_signal(signal.SIGTERM)
            try:
                server.wait(timeout=30)
            except subprocess.TimeoutExpired:
                server.kill()
                server.wait()
        if failures:
            with open(os.path.join(root, "server.log")) as f:
                print("--- server log (last 3000 characters)\n" + f.read()[-3000:])
        shutil.rmtree(root, ignore_errors=True)
    for failure in failures:
        print("FAIL: " + failure)
    print(f"{len(runs)} blocks run, {len(failures)} failures")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
