"""Blender 3.4 Cycles' alpha of a VDB through the camera usd-core reported.

    blender -b --factory-startup --python cycles_camera.py -- CAMERA.json VDB VOXEL PREFIX WxH

CAMERA.json is what scripts/usd_camera.py wrote (usd-core's GetCamera and world matrix
per frame); for frames 1 to 3 this writes PREFIX<frame>.exr: Cycles' render of VDB's
`density` as a purely absorbing medium (sigma_a = density, as `murk render --sigma-a
1,1,1 --sigma-s 0,0,0`), film transparent, one box-filtered pixel each. The camera is
built from the numbers alone: the world matrix as given (the stage's coordinates are
Blender's, as the VDB's are), the lens and gate in millimetres with a horizontal sensor
fit, the lens shift in units of the gate's width, as Blender measures it.

VOXEL is the VDB's voxel size: Blender 3.4 draws a VDB's voxels half a voxel toward +x,
+y, +z of where OpenVDB's index space puts their centres (measured on cloud.vdb through
these cameras: every frame's alpha centroid 0.17 px off murk's, mean |dA| 0.009 to
0.012; moved back by half a voxel, 0.004 px and 0.0008), so the volume object is moved
back by half a voxel: the comparison is of the cameras, not of that convention.
"""

import json
import sys

import bpy
from mathutils import Matrix

argv = sys.argv[sys.argv.index("--") + 1 :]
camera_json, vdb, voxel, prefix, res = argv
width, height = (int(v) for v in res.split("x"))

bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.cycles.samples = 64
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
scene.render.pixel_aspect_x = 1.0
scene.render.pixel_aspect_y = 1.0
scene.render.image_settings.file_format = "OPEN_EXR"
scene.render.image_settings.color_mode = "RGBA"
scene.render.image_settings.color_depth = "32"
world = bpy.data.worlds.new("black")
world.color = (0.0, 0.0, 0.0)
scene.world = world

volume = bpy.data.volumes.new("cache")
volume.filepath = vdb
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
mat.node_tree.links.new(attr.outputs["Fac"], absorb.inputs["Density"])
mat.node_tree.links.new(absorb.outputs["Volume"], out.inputs["Volume"])
volume.materials.append(mat)

cam_data = bpy.data.cameras.new("shot")
cam = bpy.data.objects.new("shot", cam_data)
scene.collection.objects.link(cam)
scene.camera = cam

for f in json.load(open(camera_json))["frames"]:
    if not 1 <= f["frame"] <= 3:
        continue
    m = f["local_to_world"]
    # usd-core's row-vector matrix, transposed into Blender's column-vector one.
    cam.matrix_world = Matrix([[m[j][i] for j in range(4)] for i in range(4)])
    cam_data.type = "ORTHO" if f["orthographic"] else "PERSP"
    cam_data.lens = f["focal_length"]
    cam_data.sensor_fit = "HORIZONTAL"
    cam_data.sensor_width = f["horizontal_aperture"]
    cam_data.sensor_height = f["vertical_aperture"]
    cam_data.shift_x = f["horizontal_offset"] / f["horizontal_aperture"]
    cam_data.shift_y = f["vertical_offset"] / f["horizontal_aperture"]
    cam_data.clip_start = f["near"]
    cam_data.clip_end = f["far"]
    scene.render.filepath = "%s%d.exr" % (prefix, f["frame"])
    bpy.ops.render.render(write_still=True)
