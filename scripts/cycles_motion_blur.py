"""Blender 3.4 Cycles' render of a VDB blurred by its velocity grid, and sharp.

    blender -b --factory-startup --python cycles_motion_blur.py -- \
        VDB VOXEL SIGMA TX,TY,TZ RX,RY,RZ FOCAL HAPERTURE VAPERTURE OPEN,CLOSE FPS \
        SAMPLES WxH PREFIX

writes PREFIX_sharp.exr (motion blur off) and PREFIX_blur.exr: the VDB's `density` as a
purely absorbing medium (sigma_a = SIGMA x density, as `murk render --sigma-a S,S,S
--sigma-s 0,0,0 --no-lights`), film transparent, one box-filtered pixel each, through
a camera translated by T and rotated by R (degrees, X first then Y then Z: USD's
`xformOp:rotateXYZ`), looking down its -z, FOCAL and the apertures in millimetres with
a horizontal fit. Blurred: the volume object's `velocity_grid` is `velocity`,
`velocity_unit` SECOND and `velocity_scale` 1, the scene at FPS, and the shutter spans
OPEN to CLOSE frames around the frame (Cycles' shutter is CLOSE - OPEN frames, centred
on the frame when OPEN = -CLOSE, starting on it when OPEN = 0, ending on it when
CLOSE = 0).

VOXEL is the VDB's voxel size: Blender 3.4 draws a VDB's voxels half a voxel toward +x,
+y, +z of where OpenVDB's index space puts them (see scripts/cycles_camera.py), so the
volume object is moved back by half a voxel.
"""

import math
import sys

import bpy

argv = sys.argv[sys.argv.index("--") + 1 :]
(vdb, voxel, sigma, t, r, focal, hap, vap, shutter, fps, samples, res, prefix) = argv
width, height = (int(v) for v in res.split("x"))
open_, close = (float(v) for v in shutter.split(","))

bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.cycles.samples = int(samples)
scene.cycles.use_denoising = False
scene.cycles.use_adaptive_sampling = False
scene.cycles.filter_type = "BOX"
scene.cycles.filter_width = 1.0
scene.cycles.volume_step_rate = 0.25
scene.cycles.volume_max_steps = 4096
scene.cycles.max_bounces = 0
scene.render.film_transparent = True
scene.render.resolution_x = width
scene.render.resolution_y = height
scene.render.resolution_percentage = 100
scene.render.fps = int(fps)
scene.render.fps_base = 1.0
scene.render.image_settings.file_format = "OPEN_EXR"
scene.render.image_settings.color_mode = "RGBA"
scene.render.image_settings.color_depth = "32"
scene.render.motion_blur_shutter = close - open_
# Cycles places its shutter on the frame by where it opens: centred, opening on the
# frame, or closing on it; another shutter has no Cycles equivalent.
if open_ == -close:
    scene.cycles.motion_blur_position = "CENTER"
elif open_ == 0.0:
    scene.cycles.motion_blur_position = "START"
elif close == 0.0:
    scene.cycles.motion_blur_position = "END"
else:
    sys.exit("shutter %s: Cycles opens it centred on, at or before the frame" % shutter)
world = bpy.data.worlds.new("black")
world.color = (0.0, 0.0, 0.0)
scene.world = world

volume = bpy.data.volumes.new("cache")
volume.filepath = vdb
volume.grids.load()
volume.velocity_grid = "velocity"
assert volume.velocity_grid == "velocity", [g.name for g in volume.grids]
volume.velocity_unit = "SECOND"
volume.velocity_scale = 1.0
volume.render.clipping = 0.0
obj = bpy.data.objects.new("cache", volume)
scene.collection.objects.link(obj)
half = -0.5 * float(voxel)
obj.location = (half, half, half)
mat = bpy.data.materials.new("absorb")
mat.use_nodes = True
nodes = mat.node_tree.nodes
nodes.clear()
out = nodes.new("ShaderNodeOutputMaterial")
absorb = nodes.new("ShaderNodeVolumeAbsorption")
absorb.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
attr = nodes.new("ShaderNodeAttribute")
attr.attribute_name = "density"
scale = nodes.new("ShaderNodeMath")
scale.operation = "MULTIPLY"
scale.inputs[1].default_value = float(sigma)
mat.node_tree.links.new(attr.outputs["Fac"], scale.inputs[0])
mat.node_tree.links.new(scale.outputs["Value"], absorb.inputs["Density"])
mat.node_tree.links.new(absorb.outputs["Volume"], out.inputs["Volume"])
volume.materials.append(mat)

cam_data = bpy.data.cameras.new("shot")
cam = bpy.data.objects.new("shot", cam_data)
scene.collection.objects.link(cam)
scene.camera = cam
cam.location = [float(v) for v in t.split(",")]
cam.rotation_mode = "XYZ"
cam.rotation_euler = [math.radians(float(v)) for v in r.split(",")]
cam_data.type = "PERSP"
cam_data.lens = float(focal)
cam_data.sensor_fit = "HORIZONTAL"
cam_data.sensor_width = float(hap)
cam_data.sensor_height = float(vap)
cam_data.clip_start = 0.01
cam_data.clip_end = 1000.0

for blur in (False, True):
    scene.render.use_motion_blur = blur
    scene.render.filepath = "%s_%s.exr" % (prefix, "blur" if blur else "sharp")
    bpy.ops.render.render(write_still=True)
