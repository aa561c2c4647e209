"""Blender 3.4 Cycles' alpha of a VDB through the camera usd-core reported.

    blender -b --factory-startup --python cycles_camera.py -- CAMERA.json VDB VOXEL PREFIX WxH

CAMERA.json is what scripts/usd_camera.py wrote (usd-core's GetCamera and world matrix
per frame); for frames 1 to 3 this writes PREFIX<frame>.exr: Cycles' render of VDB's
`density` as a purely absorbing medium (sigma_a = density, as `murk render --sigma-a
1,1,1 --sigma-s 0,0,0`), film transparent, one box-filtered pixel each. The camera is
built from the numbers alone: the world matrix as given (the stage's coordinates are
Blender's, as the VDB's are), the lens and gate in millimetres with a horizontal sensor
fit, the lens shift in units of the gate's width, as Blender measures it.

VOXEL is the VDB's voxel size: the volume is moved back by half a voxel (see
scripts/cycles_absorbing.py).
"""

import json
import os
import sys

import bpy
from mathutils import Matrix

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from cycles_absorbing import absorbing_scene, absorbing_volume, scene_camera  # noqa: E402

argv = sys.argv[sys.argv.index("--") + 1 :]
camera_json, vdb, voxel, prefix, res = argv
width, height = (int(v) for v in res.split("x"))

scene = absorbing_scene(width, height, 64)
absorbing_volume(scene, vdb, voxel)
cam, cam_data = scene_camera(scene)

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
