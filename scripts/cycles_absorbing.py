"""The Cycles (Blender 3.4) set-up that scripts/cycles_camera.py and
scripts/cycles_motion_blur.py share: a scene that renders a VDB's `density` as a purely
absorbing medium (as `murk render --sigma-s 0,0,0 --no-lights`), film transparent, one
box-filtered pixel each, 32-bit RGBA EXRs, no denoising and no adaptive sampling.

Blender 3.4 draws a VDB's voxels half a voxel toward +x, +y, +z of where OpenVDB's index
space puts their centres (measured on cloud.vdb through the USD cameras: every frame's
alpha centroid 0.17 px off murk's, mean |dA| 0.009 to 0.012; moved back by half a voxel,
0.004 px and 0.0008), so the volume object is moved back by half a voxel: the
comparisons are of cameras and blur, not of that convention.
"""

import bpy


def absorbing_scene(width, height, samples):
    """An empty Cycles scene at WIDTHxHEIGHT with SAMPLES a pixel and a black world."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = samples
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
    return scene


def absorbing_volume(scene, vdb, voxel, sigma=1.0):
    """VDB as a volume object whose `density` times SIGMA absorbs, moved back by half a
    VOXEL; returns the volume data (for its velocity settings)."""
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
    density = attr.outputs["Fac"]
    if sigma != 1.0:
        scale = nodes.new("ShaderNodeMath")
        scale.operation = "MULTIPLY"
        scale.inputs[1].default_value = float(sigma)
        mat.node_tree.links.new(density, scale.inputs[0])
        density = scale.outputs["Value"]
    mat.node_tree.links.new(density, absorb.inputs["Density"])
    mat.node_tree.links.new(absorb.outputs["Volume"], out.inputs["Volume"])
    volume.materials.append(mat)
    return volume


def scene_camera(scene):
    """A camera object (and its data) that the scene renders through."""
    cam_data = bpy.data.cameras.new("shot")
    cam = bpy.data.objects.new("shot", cam_data)
    scene.collection.objects.link(cam)
    scene.camera = cam
    return cam, cam_data
