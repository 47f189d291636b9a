# Run by Blender (blender --background --factory-startup --python THIS -- ...):
# imports a BVH file with Blender's own importer and writes the world
# position of every bone's head (a BVH joint; End Sites have no bone of
# their own) at the given file frames, in the file's unit, as JSON:
#   {"<bone>": [[x, y, z] per frame], ...}
# The axes are the file's (forward Y and up Z map onto Blender's as they
# are), so the positions compare with the library's forward kinematics.
#
#   blender --background --factory-startup --python blender_positions.py -- IN.bvh OUT.json 0,74,149
import builtins
import json
import sys

import bpy

# Debian's Blender 3.4 runs on Python 3.11, which dropped open()'s "U" mode
# that its BVH importer still asks for (io_anim_bvh/import_bvh.py: 'rU'):
# read on as plain text mode, which already takes every newline.
_open = builtins.open
builtins.open = lambda file, mode="r", *args, **kwargs: _open(file, mode.replace("U", ""), *args, **kwargs)

bvh_path, out_path, frames_text = sys.argv[sys.argv.index("--") + 1:]
frames = [int(f) for f in frames_text.split(",")]

bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_anim.bvh(filepath=bvh_path, axis_forward="Y", axis_up="Z", rotate_mode="NATIVE",
                        use_fps_scale=False, frame_start=1, global_scale=1.0)
armature = next(o for o in bpy.context.scene.objects if o.type == "ARMATURE")
heads = {bone.name: [] for bone in armature.pose.bones}
scene = bpy.context.scene
for frame in frames:
    scene.frame_set(frame + 1)  # the file's frame 0 is the scene's frame_start
    for bone in armature.pose.bones:
        heads[bone.name].append(list(armature.matrix_world @ bone.head))
with open(out_path, "w") as out:
    json.dump(heads, out)
