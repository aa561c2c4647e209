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

VOXEL is the VDB's voxel size: the volume is moved back by half a voxel (see
scripts/cycles_absorbing.py).
"""

import math
import os
import sys

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from cycles_absorbing import absorbing_scene, absorbing_volume, scene_camera  # noqa: E402

argv = sys.argv[sys.argv.index("--") + 1 :]
(vdb, voxel, sigma, t, r, focal, hap, vap, shutter, fps, samples, res, prefix) = argv
width, height = (int(v) for v in res.split("x"))
open_, close = (float(v) for v in shutter.split(","))

scene = absorbing_scene(width, height, int(samples))
scene.render.fps = int(fps)
scene.render.fps_base = 1.0
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
volume = absorbing_volume(scene, vdb, voxel, float(sigma))
volume.grids.load()
volume.velocity_grid = "velocity"
assert volume.velocity_grid == "velocity", [g.name for g in volume.grids]
volume.velocity_unit = "SECOND"
volume.velocity_scale = 1.0
volume.render.clipping = 0.0
cam, cam_data = scene_camera(scene)
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
