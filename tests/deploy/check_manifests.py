#!/usr/bin/env python3
"""deploy_manifests: the Kubernetes manifests (deploy/k8s), the image
(docker/Dockerfile) and the compose file agree with the real server.

The server's options, environment names and defaults come from its --help;
the probes' paths are asked of the real server, started with the
Deployment's own literal environment. With --kubectl, the manifests are the
output of `kubectl kustomize` (secret files written for it) and kubectl
parses every object; without it, the files the kustomization lists.

  check_manifests.py --server BIN --source-dir DIR [--kubectl KUBECTL]
Exits 0 when everything agrees, 1 with one line per disagreement."""
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
import urllib.request

import yaml

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from dockerfile_env import runtime_stage  # noqa: E402

problems = []


def check(condition, message):
    if not condition:
        problems.append(message)
    return condition


def server_options(server):
    """{env name: (flag, default or None)} from the server's --help."""
    text = subprocess.run([server, "--help"], check=True, capture_output=True, text=True).stdout
    options = {}
    for match in re.finditer(r"^\s+(--[\w-]+)\s+(.*?)\s*\(Env:(\w+)\)", text, re.M):
        flag, kind, env = match.groups()
        options[env] = (flag, kind.rsplit("=", 1)[1] if "=" in kind else None)
    if not options:
        sys.exit(f"no (Env:...) options found in {server} --help")
    return options


def kustomize_with_kubectl(kubectl, k8s_dir):
    """The manifests as `kubectl kustomize` builds them, on a copy with made-up secret files."""
    with tempfile.TemporaryDirectory() as scratch:
        copy = os.path.join(scratch, "k8s")
        shutil.copytree(k8s_dir, copy, ignore=shutil.ignore_patterns("secrets"))
        kustomization = yaml.safe_load(open(os.path.join(copy, "kustomization.yaml")))
        for generator in kustomization.get("secretGenerator", []):
            for entry in generator.get("files", []):
                path = os.path.join(copy, entry.split("=", 1)[-1])
                os.makedirs(os.path.dirname(path), exist_ok=True)
                open(path, "w").write("check-manifests\n")
        env = dict(os.environ, KUBECONFIG=os.devnull)  # nothing here may reach a cluster
        built = subprocess.run([kubectl, "kustomize", copy], capture_output=True, text=True, env=env)
        if built.returncode != 0:
            sys.exit(f"kubectl kustomize {k8s_dir}: {built.stderr.strip()}")
        # Parses every object as kubectl's own client would, with no server.
        parsed = subprocess.run([kubectl, "label", "--local", "-o", "name", "-f", "-", "checked=yes"],
                                input=built.stdout, capture_output=True, text=True, env=env)
        if parsed.returncode != 0:
            sys.exit(f"kubectl cannot read the kustomized manifests: {parsed.stderr.strip()}")
        return [doc for doc in yaml.safe_load_all(built.stdout) if doc]


def manifests_from_files(k8s_dir):
    """The files the kustomization lists, and a stub Secret per generator (its keys)."""
    kustomization = yaml.safe_load(open(os.path.join(k8s_dir, "kustomization.yaml")))
    docs = []
    for resource in kustomization["resources"]:
        docs += [doc for doc in yaml.safe_load_all(open(os.path.join(k8s_dir, resource))) if doc]
    for generator in kustomization.get("secretGenerator", []):
        keys = {entry.split("=", 1)[0] for entry in generator.get("files", [])}
        docs.append({"kind": "Secret", "metadata": {"name": generator["name"]}, "data": dict.fromkeys(keys, "")})
    return docs


def by_kind(docs, kind):
    return [doc for doc in docs if doc.get("kind") == kind]


def secret_key_exists(secrets, name, key):
    return any(s["metadata"]["name"] == name and key in {**s.get("data", {}), **s.get("stringData", {})}
               for s in secrets)


def effective_port(env_name, manifest_env, image_env, options):
    """The port the server listens on: the manifest's variable, else the image's, else the server's default."""
    for source in (manifest_env, image_env):
        if env_name in source:
            return int(source[env_name])
    return int(options[env_name][1])


def ask_server(server, source_dir, literal_env, paths):
    """Starts the real server with the Deployment's literal environment (ports,
    folders and files made local) and returns {path: HTTP status} once it serves."""
    with tempfile.TemporaryDirectory() as scratch:
        env = {k: v for k, v in os.environ.items() if not k.startswith("MM_")}
        env.update({k: v for k, v in literal_env.items() if not v.startswith("/")})
        store = os.path.join(scratch, "models")
        os.makedirs(store)
        os.symlink(os.path.join(source_dir, "models", "h36m-dkgm-h100"), os.path.join(store, "h36m-dkgm-h100"))
        ready = os.path.join(scratch, "ready.json")
        env.update(MM_MODEL_STORE=store, MM_GRPC_PORT="0", MM_REST_PORT="0", MM_ADDRESS="127.0.0.1",
                   MM_READY_FILE=ready)
        env.pop("MM_JOB_STORE", None)  # the PostgreSQL of the cluster is not here
        log = open(os.path.join(scratch, "server.log"), "w+")
        process = subprocess.Popen([server], env=env, stdout=log, stderr=subprocess.STDOUT)
        try:
            deadline = time.time() + 120
            while not os.path.exists(ready):
                if process.poll() is not None or time.time() > deadline:
                    log.seek(0)
                    sys.exit(f"the server with the Deployment's environment did not start: {log.read()[-2000:]}")
                time.sleep(0.2)
            port = json.load(open(ready))["rest_port"]
            statuses = {}
            for path in paths:
                try:
                    statuses[path] = urllib.request.urlopen(f"http://127.0.0.1:{port}{path}", timeout=10).status
                except urllib.error.HTTPError as error:
                    statuses[path] = error.code
            return statuses
        finally:
            process.send_signal(signal.SIGTERM)
            check(process.wait(timeout=60) == 0, "the server did not exit 0 on SIGTERM")


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("--server", required=True)
    parser.add_argument("--source-dir", required=True)
    parser.add_argument("--kubectl")
    args = parser.parse_args()
    options = server_options(args.server)
    k8s_dir = os.path.join(args.source_dir, "deploy", "k8s")
    docs = kustomize_with_kubectl(args.kubectl, k8s_dir) if args.kubectl else manifests_from_files(k8s_dir)
    image = runtime_stage(os.path.join(args.source_dir, "docker", "Dockerfile"))
    image_env = image["env"]

    # The image: every MM_ variable is a server option; EXPOSE is what it listens on.
    for name in image_env:
        check(not name.startswith("MM_") or name in options, f"Dockerfile ENV {name}: not an option of the server")
    image_ports = {effective_port(n, {}, image_env, options) for n in ("MM_GRPC_PORT", "MM_REST_PORT")}
    check(set(image["expose"]) == image_ports, f"Dockerfile EXPOSE {image['expose']}: the server listens on {sorted(image_ports)}")
    check(image["healthcheck"] is not None and "healthcheck.sh" in image["healthcheck"], "Dockerfile: no HEALTHCHECK running healthcheck.sh")
    check("/healthz" in open(os.path.join(args.source_dir, "docker", "healthcheck.sh")).read(), "healthcheck.sh asks no /healthz")

    # The compose file.
    compose = yaml.safe_load(open(os.path.join(args.source_dir, "docker", "compose.yaml")))
    for name, service in compose["services"].items():
        compose_env = service.get("environment", {})
        for env_name in compose_env:
            check(env_name in options, f"compose.yaml {name}: environment {env_name} is not an option of the server")
        inside = {int(str(p).rsplit(":", 1)[-1]) for p in service.get("ports", [])}
        check(inside == image_ports, f"compose.yaml {name}: publishes {sorted(inside)}, the server listens on {sorted(image_ports)}")
        mounts = {v.split(":")[1] for v in service.get("volumes", [])}
        for folder in ("MM_MODEL_STORE", "MM_STATE_DIR", "MM_DATA_ROOT"):
            check(image_env.get(folder) in mounts, f"compose.yaml {name}: no volume on {folder}={image_env.get(folder)}")

    # The Deployment.
    deployments = by_kind(docs, "Deployment")
    if not check(len(deployments) == 1, f"expected one Deployment, found {len(deployments)}"):
        return
    deployment = deployments[0]
    pod = deployment["spec"]["template"]
    check(deployment["spec"].get("replicas", 1) >= 2, "the Deployment runs fewer than two replicas")
    check(pod["spec"].get("securityContext", {}).get("runAsNonRoot") is True, "the pod does not require a non-root user")
    containers = pod["spec"]["containers"]
    server = containers[0]
    manifest_env = {e["name"]: e.get("value") for e in server.get("env", [])}
    literal_env = {k: v for k, v in manifest_env.items() if v is not None}
    secrets = by_kind(docs, "Secret")
    for entry in server.get("env", []):
        check(entry["name"] in options, f"Deployment env {entry['name']}: not an option of the server")
        ref = entry.get("valueFrom", {}).get("secretKeyRef")
        if ref:
            check(secret_key_exists(secrets, ref["name"], ref["key"]), f"env {entry['name']}: no Secret {ref['name']} with key {ref['key']}")
    check("MM_JOB_STORE" in manifest_env and "valueFrom" in next(e for e in server["env"] if e["name"] == "MM_JOB_STORE"),
          "replicas need MM_JOB_STORE (a postgresql:// URI) from a Secret")
    check("MM_AUTH_TOKEN_FILE" in manifest_env or any(e["name"] == "MM_AUTH_TOKEN" and "valueFrom" in e for e in server["env"]),
          "no token from a Secret (MM_AUTH_TOKEN_FILE or MM_AUTH_TOKEN)")

    ports = {p["name"]: p["containerPort"] for p in server.get("ports", [])}
    for name, env_name in (("grpc", "MM_GRPC_PORT"), ("http", "MM_REST_PORT")):
        expected = effective_port(env_name, literal_env, image_env, options)
        check(ports.get(name) == expected, f"container port {name}: {ports.get(name)}, the server listens on {expected} ({env_name})")

    def probe_path(kind, expected):
        probe = server.get(kind, {}).get("httpGet", {})
        check(probe.get("path") == expected, f"{kind}: path {probe.get('path')}, expected {expected}")
        check(probe.get("port") in (ports.get("http"), "http"), f"{kind}: port {probe.get('port')} is not the REST port")
        return probe.get("path")
    asked = {probe_path("readinessProbe", "/readyz"), probe_path("livenessProbe", "/healthz")}
    if "startupProbe" in server:
        asked.add(server["startupProbe"]["httpGet"]["path"])

    resources = server.get("resources", {})
    for kind in ("cpu", "memory"):
        check(kind in resources.get("requests", {}) and kind in resources.get("limits", {}), f"no {kind} request and limit")

    # Volumes: every mount has a volume, every claim a PersistentVolumeClaim
    # shared by all replicas, and the server's folders are mounts.
    volumes = {v["name"]: v for v in pod["spec"].get("volumes", [])}
    claims = {c["metadata"]["name"]: c for c in by_kind(docs, "PersistentVolumeClaim")}
    mounts = {}
    for mount in server.get("volumeMounts", []):
        mounts[mount["mountPath"]] = mount["name"]
        volume = volumes.get(mount["name"])
        if not check(volume is not None, f"volumeMount {mount['name']}: no such volume"):
            continue
        claim = volume.get("persistentVolumeClaim", {}).get("claimName")
        if claim:
            check(claim in claims and "ReadWriteMany" in claims[claim]["spec"]["accessModes"],
                  f"volume {mount['name']}: claim {claim} missing or not ReadWriteMany (replicas share it)")
        secret = volume.get("secret")
        if secret:
            for item in secret.get("items", []):
                check(secret_key_exists(secrets, secret["secretName"], item["key"]), f"volume {mount['name']}: no Secret key {item['key']}")
    for folder in ("MM_MODEL_STORE", "MM_STATE_DIR", "MM_DATA_ROOT"):
        path = literal_env.get(folder, image_env.get(folder))
        check(path in mounts and "persistentVolumeClaim" in volumes.get(mounts[path], {}),
              f"{folder}={path}: not a mounted claim")
    token_file = literal_env.get("MM_AUTH_TOKEN_FILE")
    if token_file:
        check(os.path.dirname(token_file) in mounts, f"MM_AUTH_TOKEN_FILE={token_file}: not in a mounted volume")

    # The Service reaches the pods on both named ports.
    services = [s for s in by_kind(docs, "Service")
                if set(s["spec"].get("selector", {}).items()) <= set(pod["metadata"]["labels"].items())]
    if check(len(services) == 1, "expected one Service selecting the server's pods"):
        targets = {p.get("targetPort") for p in services[0]["spec"]["ports"]}
        check(targets >= {"grpc", "http"} or targets >= set(ports.values()), f"Service targets {targets}, expected grpc and http")
    check(by_kind(docs, "StatefulSet") or "external" in open(os.path.join(k8s_dir, "kustomization.yaml")).read(),
          "no PostgreSQL StatefulSet and no external database named")

    # The probes' paths, asked of the real server with the Deployment's environment.
    statuses = ask_server(args.server, args.source_dir, {**{k: v for k, v in image_env.items() if k.startswith("MM_")}, **literal_env}, sorted(asked))
    for path, status in statuses.items():
        check(status == 200, f"probe path {path}: the server answers {status}, expected 200")


main()
for problem in problems:
    print("FAIL:", problem)
print(f"deploy_manifests: {'ok' if not problems else len(problems)} ({'kubectl kustomize' if '--kubectl' in sys.argv else 'files'})")
sys.exit(1 if problems else 0)
