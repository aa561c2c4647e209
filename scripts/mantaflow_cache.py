"""A real Mantaflow smoke cache, baked headless by Blender 3.4.

    blender -b --factory-startup --python mantaflow_cache.py -- CACHEDIR RES FRAMES [FPS [KIND]]

bakes a gas domain (3 x 2 x 2 units, x from -1.5, z from 0, its longest side RES
voxels) with a sphere of radius 0.25 at (-0.9, 0, 0.6) pouring smoke in with an initial
velocity of 3 units a second along +x (KIND `smoke`, the default; `fire` pours fire
and smoke, `BOTH` in Blender's words), frames 1 to FRAMES at FPS (24), into
CACHEDIR/data/fluid_data_####.vdb: OpenVDB files as Blender writes them (`density`,
`flame`, `shadow`, `temperature` and a staggered vec3 `velocity`, half floats).

fixtures/caches/mantaflow_baked.vdb is frame 8 of RES 32 (the smoke drifting along +x
and rising), for tests/motion_blur_peers.rs.

Headless, Blender 3.4's view layer update after the flow is added raises a SystemError
(inside Mantaflow's Python: 'NoneType' object has no attribute 'getDataPointer'), and
any operator called next raises it again; updating once and catching it lets the bake
run, and its frames come out the same every time.
"""

import os
import sys

import bpy

argv = sys.argv[sys.argv.index("--") + 1 :]
out, res, frames = argv[0], int(argv[1]), int(argv[2])
fps = int(argv[3]) if len(argv) > 3 else 24
kind = argv[4] if len(argv) > 4 else "smoke"

bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.frame_start = 1
scene.frame_end = frames
scene.render.fps = fps

bpy.ops.mesh.primitive_cube_add(size=2.0, location=(0, 0, 1))
domain = bpy.context.active_object
domain.scale = (1.5, 1.0, 1.0)
bpy.ops.object.transform_apply(scale=True)
mod = domain.modifiers.new("Fluid", "FLUID")
mod.fluid_type = "DOMAIN"
ds = mod.domain_settings
ds.domain_type = "GAS"
ds.resolution_max = res
ds.cache_type = "ALL"
ds.cache_data_format = "OPENVDB"
ds.cache_directory = out
ds.cache_frame_start = 1
ds.cache_frame_end = frames

bpy.ops.mesh.primitive_uv_sphere_add(radius=0.25, location=(-0.9, 0, 0.6))
flow = bpy.context.active_object
fm = flow.modifiers.new("Fluid", "FLUID")
fm.fluid_type = "FLOW"
fs = fm.flow_settings
fs.flow_type = {"smoke": "SMOKE", "fire": "BOTH"}[kind]
fs.flow_behavior = "INFLOW"
fs.use_initial_velocity = True
fs.velocity_coord = (3.0, 0.0, 0.0)

for o in scene.objects:
    o.select_set(False)
domain.select_set(True)
bpy.context.view_layer.objects.active = domain
try:
    bpy.context.view_layer.update()
except SystemError as e:
    print("view layer update:", e)
result = bpy.ops.fluid.bake_all()
if result != {"FINISHED"}:
    sys.exit("bake: %s" % result)
data = os.path.join(out, "data")
for f in sorted(os.listdir(data)):
    print(os.path.join(data, f), os.path.getsize(os.path.join(data, f)))
