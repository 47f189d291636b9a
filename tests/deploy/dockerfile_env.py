#!/usr/bin/env python3
"""The runtime stage of docker/Dockerfile as data: its ENV, EXPOSE and
HEALTHCHECK. As a program, prints the stage's MM_* variables as KEY=VALUE
lines (the environment the image gives the server)."""
import re
import shlex
import sys


def runtime_stage(path):
    """Returns {"env": {KEY: VALUE}, "expose": [ports], "healthcheck": str or None}
    of the Dockerfile's last stage."""
    text = re.sub(r"\\\n", " ", open(path).read())  # continuation lines joined
    lines = [l.strip() for l in text.splitlines() if l.strip() and not l.strip().startswith("#")]
    last_from = max(i for i, l in enumerate(lines) if l.upper().startswith("FROM "))
    stage = {"env": {}, "expose": [], "healthcheck": None}
    for line in lines[last_from + 1:]:
        instruction, _, rest = line.partition(" ")
        instruction = instruction.upper()
        if instruction == "ENV":
            for word in shlex.split(rest):
                key, sep, value = word.partition("=")
                if not sep:
                    raise ValueError(f"{path}: ENV {rest}: expected KEY=VALUE pairs")
                stage["env"][key] = value
        elif instruction == "EXPOSE":
            stage["expose"] += [int(p.split("/")[0]) for p in rest.split()]
        elif instruction == "HEALTHCHECK":
            stage["healthcheck"] = rest
    return stage


if __name__ == "__main__":
    for key, value in runtime_stage(sys.argv[1])["env"].items():
        if key.startswith("MM_"):
            print(f"{key}={value}")
