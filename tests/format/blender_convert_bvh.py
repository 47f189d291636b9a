# Run by Blender (blender --background --factory-startup --python THIS -- ...):
# imports a BVH with Blender's own importer (its default axes: the file's Y
# up becomes Blender's Z) at `scale` metres per file unit and exports it with
# Blender's own glTF or FBX exporter (their default axes turn it back, so the
# written file has the BVH's axes), every frame baked, at the file's rate.
# Several files in one run cost one start of Blender (seconds).
#
#   blender --background --factory-startup --python blender_convert_bvh.py -- IN.bvh OUT.glb|OUT.fbx [IN OUT ...] 0.01
import builtins
import sys

import bpy

# Debian's Blender 3.4 runs on Python 3.11, which dropped open()'s "U" mode
# that its BVH importer still asks for: read on in plain text mode.
_open = builtins.open
builtins.open = lambda file, mode="r", *args, **kwargs: _open(file, mode.replace("U", ""), *args, **kwargs)

arguments = sys.argv[sys.argv.index("--") + 1:]
scale = float(arguments[-1])


def convert(source, out):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_anim.bvh(filepath=source, global_scale=scale, rotate_mode="NATIVE", use_fps_scale=False,
                            update_scene_fps=True, update_scene_duration=True, frame_start=1)
    scene = bpy.context.scene
    # The importer ends the scene one frame after the action; the FBX exporter
    # bakes the scene's range.
    action = scene.objects[0].animation_data.action
    scene.frame_end = int(action.frame_range[1])
    if out.endswith(".fbx"):
        # FBX keeps no rest pose of an armature without a mesh beside its bones'
        # transforms, which Blender writes as the pose at the current frame (its
        # exporter's fbx_object_tx(rest=False)): frame 0, before the animation,
        # gets the rest pose and is the current frame when the file is written.
        armature = next(o for o in scene.objects if o.type == "ARMATURE")
        for bone in armature.pose.bones:
            bone.location = (0, 0, 0)
            bone.keyframe_insert("location", frame=0)
            if bone.rotation_mode == "QUATERNION":
                bone.rotation_quaternion = (1, 0, 0, 0)
                bone.keyframe_insert("rotation_quaternion", frame=0)
            else:
                bone.rotation_euler = (0, 0, 0)
                bone.keyframe_insert("rotation_euler", frame=0)
        scene.frame_set(0)
        bpy.ops.export_scene.fbx(filepath=out, bake_anim=True, add_leaf_bones=False, bake_anim_use_nla_strips=False,
                                 bake_anim_use_all_actions=False, bake_anim_simplify_factor=0.0)
    else:
        bpy.ops.export_scene.gltf(filepath=out, export_format="GLB", export_animations=True,
                                  export_force_sampling=True, export_optimize_animation_size=False)


for source, out in zip(arguments[0:-1:2], arguments[1:-1:2]):
    convert(source, out)
