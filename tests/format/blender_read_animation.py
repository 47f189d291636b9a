# Run by Blender (blender --background --factory-startup --python THIS -- ...):
# imports a glTF file with Blender's own importer and writes what Blender
# made of it as JSON:
#   {"joints": [bone names], "frames": keys, "rate": Hz,
#    "positions": {"<bone>": [[x, y, z] per key], ...}}
# frames and rate from the keyframes Blender placed (glTF holds times, which
# Blender puts at time x the scene's frames a second), positions the bones'
# heads at each key in metres, in the file's axes (Blender's importer turns
# glTF's Y up into its Z up; turned back here).
#
#   blender --background --factory-startup --python blender_read_animation.py -- IN.glb OUT.json
import json
import math
import sys

import bpy

source, out = sys.argv[sys.argv.index("--") + 1:]
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=source)
scene = bpy.context.scene
armature = next(o for o in scene.objects if o.type == "ARMATURE")
action = armature.animation_data.action
keys = [k.co[0] for k in next(c for c in action.fcurves if c.data_path.endswith("rotation_quaternion")).keyframe_points]
fps = scene.render.fps / scene.render.fps_base
rate = fps * (len(keys) - 1) / (keys[-1] - keys[0]) if len(keys) > 1 else 0
positions = {bone.name: [] for bone in armature.pose.bones}
for key in keys:
    whole = math.floor(key)
    scene.frame_set(whole, subframe=key - whole)
    for bone in armature.pose.bones:
        x, y, z = armature.matrix_world @ bone.head
        positions[bone.name].append([x, z, -y])
with open(out, "w") as f:
    json.dump({"joints": [b.name for b in armature.pose.bones], "frames": len(keys), "rate": rate,
               "positions": positions}, f)
