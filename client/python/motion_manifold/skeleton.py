"""The skeleton of a model's motions, as DescribeModel gives it
(ModelInfo.skeleton_json), with the BVH layout its motions are written in.

The JSON is that of the library's format/skeleton.h: {"name", "joints":
[{"index", "name", "parent", "offset": [x, y, z] in mm}]} and, for a rig
learnt from BVH files, "bvh": {"millimetres_per_unit", "joints":
[{"channels", "end_site"}]}. A skeleton without one (H3.6M's) is written as
the library writes it: leaves as End Sites, the root with Xposition
Yposition Zposition Zrotation Yrotation Xrotation, every other joint
Zrotation Yrotation Xrotation, lengths in mm.
"""

import json
from dataclasses import dataclass

import numpy as np

DEFAULT_ROTATION_CHANNELS = ["Zrotation", "Yrotation", "Xrotation"]
POSITION_CHANNELS = ["Xposition", "Yposition", "Zposition"]


@dataclass
class Skeleton:
    """Joint names, parents (-1 for the root; parents precede children) and
    offsets from the parent (mm), with the BVH layout of each joint
    (`channels`, `end_site`) and its file unit (`millimetres_per_unit`).
    `layout` and `columns` are those of the model's motions (3 + 3 x joints)."""

    name: str
    joint_names: list
    parents: list
    offsets_mm: np.ndarray
    channels: list
    end_site: list
    millimetres_per_unit: float
    layout: str

    @property
    def joint_count(self):
        return len(self.joint_names)

    @property
    def columns(self):
        return 3 + 3 * self.joint_count

    @classmethod
    def from_json(cls, text, layout="", source="skeleton_json"):
        """Parses the skeleton JSON; raises ValueError naming `source` and the
        key when it is not one."""
        try:
            document = json.loads(text)
            joints = document["joints"]
            names = [str(j["name"]) for j in joints]
            parents = [int(j["parent"]) for j in joints]
            offsets = np.array([[float(v) for v in j["offset"]] for j in joints], dtype=np.float64).reshape(-1, 3)
        except (ValueError, KeyError, TypeError) as error:
            raise ValueError(f"{source}: not a skeleton ({error!r}), expected {{\"name\", \"joints\": "
                             "[{\"name\", \"parent\", \"offset\"}]}") from error
        if not names:
            raise ValueError(f"{source}: a skeleton without joints")
        layout = layout or f"expmap-{3 + 3 * len(names)}"
        bvh = document.get("bvh")
        if bvh:
            channels = [list(j.get("channels", [])) for j in bvh["joints"]]
            end_site = [bool(j.get("end_site", False)) for j in bvh["joints"]]
            unit = float(bvh.get("millimetres_per_unit", 1.0))
            if len(channels) != len(names):
                raise ValueError(f"{source}: a BVH layout of {len(channels)} joints for {len(names)} joints")
        else:
            has_children = set(p for p in parents if p >= 0)
            end_site = [j > 0 and j not in has_children for j in range(len(names))]
            channels = [[] if end_site[j] else (POSITION_CHANNELS if j == 0 else []) + DEFAULT_ROTATION_CHANNELS
                        for j in range(len(names))]
            unit = 1.0
        return cls(str(document.get("name", "")), names, parents, offsets, channels, end_site, unit, layout)

    @classmethod
    def from_bvh(cls, bvh, name, millimetres_per_unit=1.0):
        """The hierarchy of a parsed BVH file (bvh.parse_bvh) as a skeleton named
        `name`, one joint per BVH joint or End Site in file order (End Sites
        named "<parent>_End", "_2", ... where taken), offsets times
        `millimetres_per_unit` (10 for a file in cm), its BVH layout that of
        the file: the library's bvh_skeleton (format/bvh_file.h), the
        rig a model trained on such files speaks."""
        names = {j.name for j in bvh.joints if not j.end_site}
        joint_names = []
        for joint in bvh.joints:
            if not joint.end_site:
                joint_names.append(joint.name)
                continue
            base = bvh.joints[joint.parent].name + "_End"
            candidate, n = base, 2
            while candidate in names:
                candidate, n = f"{base}_{n}", n + 1
            names.add(candidate)
            joint_names.append(candidate)
        columns = 3 + 3 * len(joint_names)
        return cls(name, joint_names, [j.parent for j in bvh.joints],
                   np.array([j.offset for j in bvh.joints], dtype=np.float64) * millimetres_per_unit,
                   [list(j.channels) for j in bvh.joints], [j.end_site for j in bvh.joints],
                   float(millimetres_per_unit), f"expmap-{columns}")

    @classmethod
    def from_model_info(cls, info):
        """The skeleton of a ModelInfo message (DescribeModel's reply)."""
        return cls.from_json(info.skeleton_json, info.layout, f"model {info.name}: skeleton_json")
