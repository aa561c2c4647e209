"""Opens an EXR in Blender's compositor as a user would (an Image node) and reports what
the compositor sees: the Image node's output sockets (the passes), as JSON, and the
alpha the compositor places in the frame, written by its Composite node as a float EXR.

    blender -b --factory-startup -noaudio --python scripts/blender_compositor.py -- IN.exr W H OUT.json OUT_ALPHA.exr

Run by tests/blender_compositor.rs, which compares the plane with the EXR's own alpha.
"""
import json
import sys

import bpy

path, width, height, out, alpha_out = sys.argv[sys.argv.index("--") + 1:]
width, height = int(width), int(height)
scene = bpy.context.scene
scene.render.engine = "BLENDER_WORKBENCH"
scene.render.resolution_x, scene.render.resolution_y = width, height
scene.render.resolution_percentage = 100
scene.render.use_compositing = True
scene.use_nodes = True
tree = scene.node_tree
for n in list(tree.nodes):
    tree.nodes.remove(n)
image = bpy.data.images.load(path)
node = tree.nodes.new("CompositorNodeImage")
node.image = image
sockets = [s.name for s in node.outputs if s.enabled]
composite = tree.nodes.new("CompositorNodeComposite")
composite.use_alpha = False
tree.links.new(node.outputs["Alpha"], composite.inputs["Image"])
settings = scene.render.image_settings
settings.file_format = "OPEN_EXR"
settings.color_mode = "RGB"
settings.color_depth = "32"
settings.exr_codec = "NONE"
scene.render.filepath = alpha_out
scene.render.use_file_extension = False
bpy.ops.render.render(write_still=True)
with open(out, "w") as f:
    json.dump({"blender": bpy.app.version_string, "image_type": image.type,
               "sockets": sockets}, f)
