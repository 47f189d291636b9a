"""BVH files of a model's skeleton to and from its motions, as the server and
the command-line client convert them (format/skeleton_bvh.h).

Reading: joints are matched to the skeleton's by name (a leaf of the skeleton
may be an End Site in the file), any rotation channel order, position
channels of joints other than the root ignored (the bone lengths are the
skeleton's); a joint's exponential map is its local rotation for row vectors,
the transpose of BVH's column-vector matrix; the root's columns are the
change of its position since the previous frame in mm (frame 0: the position
itself). Writing: the same backwards, the root's position the running sum of
the changes, values with 6 decimals. Another hierarchy is refused naming what
differs.
"""

import io
import math
from dataclasses import dataclass

import numpy as np

from .motion import Motion, MODEL_RATE
from .motion_text import write_file_atomically
from .rotations import axis_rotation, expmap_to_matrix, matrix_to_euler_degrees, matrix_to_expmap

CHANNEL_NAMES = ["Xposition", "Yposition", "Zposition", "Xrotation", "Yrotation", "Zrotation"]
MIN_FRAME_TIME, MAX_FRAME_TIME = 1e-3, 1.0  # seconds: 1 to 1000 frames a second, as the server reads


class BvhError(ValueError):
    """A BVH file that cannot be read, or is not of the skeleton: the message
    names the file, the line where there is one, and what was expected."""


@dataclass
class BvhJoint:
    name: str  # "" for an End Site
    parent: int  # index into BvhFile.joints, -1 for the root
    offset: tuple
    channels: list  # channel names in file order
    end_site: bool = False


@dataclass
class BvhFile:
    joints: list  # depth-first pre-order, as in the file
    frame_time: float  # seconds
    values: np.ndarray  # frames x channels, degrees and file units

    @property
    def frame_rate(self):
        """1 / frame time rounded to a millionth of a hertz, as the server reads it
        (0.00833333333 s is 120 Hz)."""
        return round(1e6 / self.frame_time) / 1e6


def _number(token, line, source, what):
    try:
        value = float(token)
    except ValueError:
        raise BvhError(f"{source}:{line}: \"{token}\" is not a number, expected {what}") from None
    if not math.isfinite(value):
        raise BvhError(f"{source}:{line}: \"{token}\" is not finite, expected {what}")
    return value


def parse_bvh(text, source="BVH"):
    """Parses BVH text (str or bytes); raises BvhError "<source>:<line>: ..."."""
    if isinstance(text, (bytes, bytearray)):
        text = text.decode("utf-8", errors="replace")
    text = text.lstrip("\ufeff")
    lines = text.split("\n")
    tokens = []  # (word, line) of the hierarchy, up to MOTION
    motion_line = None
    for number, line in enumerate(lines, 1):
        words = line.split()
        if words and words[0] == "MOTION":
            motion_line = number
            break
        tokens.extend((word, number) for word in words)
    position = 0

    def next_token(expected):
        nonlocal position
        if position >= len(tokens):
            raise BvhError(f"{source}: unexpected end of the hierarchy, expected {expected}")
        position += 1
        return tokens[position - 1]

    def expect(word):
        found, line = next_token(word)
        if found != word:
            raise BvhError(f"{source}:{line}: found \"{found}\", expected \"{word}\"")

    expect("HIERARCHY")
    expect("ROOT")
    joints, open_joints, names = [], [], set()

    def begin_joint(parent, end_site):
        if end_site:
            expect("Site")
            name = ""
        else:
            name, line = next_token("a joint name")
            if name in names:
                raise BvhError(f"{source}:{line}: joint name \"{name}\" appears twice")
            names.add(name)
        expect("{")
        expect("OFFSET")
        offset = tuple(_number(*next_token("an offset value"), source, "an offset value") for _ in range(3))
        channels = []
        if not end_site:
            expect("CHANNELS")
            count_text, line = next_token("a channel count")
            if count_text not in ("0", "1", "2", "3", "4", "5", "6"):
                raise BvhError(f"{source}:{line}: channel count {count_text}, expected 0 to 6")
            for _ in range(int(count_text)):
                channel, line = next_token("a channel name")
                if channel not in CHANNEL_NAMES or channel in channels:
                    raise BvhError(f"{source}:{line}: channel \"{channel}\" of joint {name}, expected one of "
                                   f"{' '.join(CHANNEL_NAMES)}, none twice")
                channels.append(channel)
        joints.append(BvhJoint(name, parent, offset, channels, end_site))
        open_joints.append(len(joints) - 1)

    begin_joint(-1, False)
    while open_joints:
        word, line = next_token("JOINT, End Site or }")
        if word == "}":
            open_joints.pop()
        elif joints[open_joints[-1]].end_site:
            raise BvhError(f"{source}:{line}: found \"{word}\" in an End Site, expected }}")
        elif word == "JOINT":
            begin_joint(open_joints[-1], False)
        elif word == "End":
            begin_joint(open_joints[-1], True)
        else:
            raise BvhError(f"{source}:{line}: found \"{word}\", expected JOINT, End Site or }}")
    if motion_line is None:
        raise BvhError(f"{source}: no MOTION section after the hierarchy")
    header = [(lines[i].split(), i + 1) for i in range(motion_line, min(motion_line + 2, len(lines)))]
    if len(header) < 2 or header[0][0][:1] != ["Frames:"] or header[1][0][:2] != ["Frame", "Time:"] \
            or len(header[0][0]) != 2 or len(header[1][0]) != 3:
        raise BvhError(f"{source}:{motion_line + 1}: expected \"Frames: N\" and \"Frame Time: T\" after MOTION")
    frames = _number(header[0][0][1], header[0][1], source, "a frame count")
    if frames != int(frames) or frames < 1:
        raise BvhError(f"{source}:{header[0][1]}: frame count {header[0][0][1]}, expected a whole number >= 1")
    frames = int(frames)
    frame_time = _number(header[1][0][2], header[1][1], source, "a frame time in seconds")
    if not MIN_FRAME_TIME <= frame_time <= MAX_FRAME_TIME:
        raise BvhError(f"{source}:{header[1][1]}: frame time {header[1][0][2]} s, expected 0.001 to 1 s")
    channel_count = sum(len(j.channels) for j in joints)
    if channel_count == 0:
        raise BvhError(f"{source}: the hierarchy has no channels, so frames cannot hold values")
    body = "\n".join(lines[motion_line + 2:])
    values = np.fromstring(body, dtype=np.float64, sep=" ") if body.strip() else np.zeros(0)
    if values.size != frames * channel_count or not np.all(np.isfinite(values)):
        _explain_frames(lines, motion_line + 2, frames, channel_count, source)
    return BvhFile(joints, frame_time, values.reshape(frames, channel_count))


def _explain_frames(lines, first, frames, channels, source):
    """Raises the BvhError that says which frame line is wrong."""
    seen = 0
    for number in range(first, len(lines)):
        words = lines[number].split()
        if not words:
            continue
        seen += 1
        if seen > frames:
            raise BvhError(f"{source}:{number + 1}: more frames than the {frames} that \"Frames:\" declares")
        if len(words) != channels:
            raise BvhError(f"{source}:{number + 1}: {len(words)} values in frame {seen}, expected {channels} "
                           "(one a channel)")
        for word in words:
            _number(word, number + 1, source, "a channel value")
    raise BvhError(f"{source}: \"Frames:\" declares {frames} frames but the file holds {seen}")


def bvh_text(bvh):
    """BVH text of a BvhFile: tab-indented hierarchy, values with 6 decimals,
    the frame time with 9 significant digits (the server's writer's layout)."""
    out = io.StringIO()
    out.write("HIERARCHY\n")
    open_joints = []
    for j, joint in enumerate(bvh.joints):
        while open_joints and open_joints[-1] != joint.parent:
            open_joints.pop()
            out.write("\t" * len(open_joints) + "}\n")
        indent = "\t" * len(open_joints)
        out.write(indent + ("End Site" if joint.end_site else ("ROOT " if j == 0 else "JOINT ") + joint.name) + "\n")
        out.write(indent + "{\n")
        out.write(indent + "\tOFFSET %.6f %.6f %.6f\n" % tuple(joint.offset))
        if not joint.end_site:
            out.write(indent + "\tCHANNELS " + " ".join([str(len(joint.channels))] + joint.channels) + "\n")
        open_joints.append(j)
    while open_joints:
        open_joints.pop()
        out.write("\t" * len(open_joints) + "}\n")
    out.write("MOTION\nFrames: %d\nFrame Time: %.9g\n" % (bvh.values.shape[0], bvh.frame_time))
    np.savetxt(out, bvh.values, fmt="%.6f", delimiter=" ")
    return out.getvalue()


def _match(skeleton, bvh, source):
    """For each skeleton joint, the index of the file's joint carrying its
    rotation, or -1 for a leaf that is an End Site in the file."""
    by_name = {j.name: i for i, j in enumerate(bvh.joints) if not j.end_site}
    with_end_sites = {j.parent for j in bvh.joints if j.end_site}
    has_children = {p for p in skeleton.parents if p >= 0}
    match, missing, wrong_parent = [], [], []
    for j, name in enumerate(skeleton.joint_names):
        parent = skeleton.parents[j]
        parent_name = skeleton.joint_names[parent] if parent >= 0 else ""
        if name not in by_name:
            leaf = j not in has_children
            if leaf and by_name.get(parent_name, -2) in with_end_sites:
                match.append(-1)
                continue
            missing.append(name + (f" (or an End Site under {parent_name})" if leaf and j > 0 else ""))
            match.append(-1)
            continue
        index = by_name[name]
        file_parent = bvh.joints[index].parent
        file_parent_name = bvh.joints[file_parent].name if file_parent >= 0 else ""
        if file_parent_name != parent_name:
            wrong_parent.append(f"{name}'s parent is {file_parent_name or 'none (it is the ROOT)'}, expected "
                                f"{parent_name or 'none (the ROOT)'}")
        match.append(index)
    unexpected = sorted(set(by_name) - set(skeleton.joint_names))
    if missing or unexpected or wrong_parent:
        label = "the H3.6M skeleton (h36m-32)" if skeleton.name == "h36m-32" else f"the skeleton \"{skeleton.name}\""
        message = f"{source}: not {label}"
        for what, names in (("missing joints", missing), ("unexpected joints", unexpected),
                            ("a different parent", wrong_parent)):
            if names:
                message += f"; {what}: " + ", ".join(names[:8]) + (f" and {len(names) - 8} more" if len(names) > 8 else "")
        raise BvhError(message)
    return match


def imported_frame_count(frames, frame_time):
    """Frames at 25 Hz that `frames` file frames of `frame_time` make: one every
    1/25 s from the first frame's time to the last's."""
    return int(math.floor((frames - 1) * frame_time * MODEL_RATE + 1e-9)) + 1 if frames >= 1 else 0


def motion_from_bvh(skeleton, bvh, source="BVH", at_model_rate=False):
    """The file's frames as a Motion of the skeleton's layout: every frame at
    the file's own rate (what a take sends), or with `at_model_rate` at 25 Hz,
    each the file's frame nearest in time to k/25 s (ties to the later)."""
    match = _match(skeleton, bvh, source)
    frames = bvh.values.shape[0]
    if at_model_rate:
        k = np.arange(imported_frame_count(frames, bvh.frame_time))
        rows = np.minimum(np.floor(k / MODEL_RATE / bvh.frame_time + 0.5).astype(np.int64), frames - 1)
        rate = MODEL_RATE
    else:
        rows, rate = np.arange(frames), bvh.frame_rate
    values = bvh.values[rows]
    first_channel = np.cumsum([0] + [len(j.channels) for j in bvh.joints])
    out = np.zeros((len(rows), skeleton.columns), dtype=np.float64)
    for j, index in enumerate(match):
        if index < 0:
            continue
        joint = bvh.joints[index]
        local = np.broadcast_to(np.eye(3), (len(rows), 3, 3))
        position = np.zeros((len(rows), 3))
        for c, channel in enumerate(joint.channels):
            axis = CHANNEL_NAMES.index(channel) % 3
            column = values[:, first_channel[index] + c]
            if channel.endswith("position"):
                position[:, axis] = column * skeleton.millimetres_per_unit
            else:
                local = local @ axis_rotation(axis, np.radians(column))
        out[:, 3 + 3 * j:6 + 3 * j] = matrix_to_expmap(np.swapaxes(local, -1, -2))
        if j == 0:
            out[:, :3] = np.diff(position, axis=0, prepend=np.zeros((1, 3)))
    return Motion(out.astype(np.float32), rate, skeleton.layout)


def motion_to_bvh(skeleton, motion):
    """A BvhFile of the motion in the skeleton's BVH layout at the motion's rate."""
    if motion.columns != skeleton.columns:
        raise ValueError(f"BVH export: a motion of {motion.columns} columns, expected {skeleton.columns} "
                         f"(3 + 3 x {skeleton.joint_count} joints of {skeleton.name})")
    if not 1.0 <= motion.frame_rate <= 1000.0:
        raise ValueError(f"BVH export: rate {motion.frame_rate} Hz, expected 1 to 1000 Hz")
    if motion.frames < 1 or not np.all(np.isfinite(motion.values)):
        raise ValueError("BVH export: the motion has no frames or a value that is not finite")
    values = motion.values.astype(np.float64)
    root = np.cumsum(values[:, :3], axis=0)
    unit = skeleton.millimetres_per_unit
    joints, columns = [], []
    for j in range(skeleton.joint_count):
        channels = skeleton.channels[j]
        joints.append(BvhJoint("" if skeleton.end_site[j] else skeleton.joint_names[j], skeleton.parents[j],
                               tuple(skeleton.offsets_mm[j] / unit), list(channels), skeleton.end_site[j]))
        if not channels:
            continue
        axes = [CHANNEL_NAMES.index(c) % 3 for c in channels if c.endswith("rotation")]
        order = axes + [a for a in range(3) if a not in axes]
        local = np.swapaxes(expmap_to_matrix(values[:, 3 + 3 * j:6 + 3 * j]), -1, -2)
        degrees = matrix_to_euler_degrees(order, local)
        rotation = 0
        for channel in channels:
            if channel.endswith("position"):
                axis = CHANNEL_NAMES.index(channel)
                columns.append(root[:, axis] / unit if j == 0 else np.zeros(motion.frames))
            else:
                columns.append(degrees[:, rotation])
                rotation += 1
    return BvhFile(joints, 1.0 / motion.frame_rate, np.stack(columns, axis=1))


def read_bvh(source, skeleton, at_model_rate=False):
    """A BVH file (a path, or its bytes) as a Motion of the skeleton, as motion_from_bvh reads it."""
    if isinstance(source, (bytes, bytearray)):
        return motion_from_bvh(skeleton, parse_bvh(source, "BVH"), "BVH", at_model_rate)
    with open(source, "rb") as f:
        return motion_from_bvh(skeleton, parse_bvh(f.read(), str(source)), str(source), at_model_rate)


def write_bvh(motion, skeleton, path):
    """Writes the motion as BVH of the skeleton to `path` (a temporary file beside it, then renamed)."""
    write_file_atomically(path, bvh_text(motion_to_bvh(skeleton, motion)))
