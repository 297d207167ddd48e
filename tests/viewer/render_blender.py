# Imports glTF files with Blender's own glTF importer and renders each with Cycles, for the real-client stage
# (tests/viewer/test_blender.cpp).
#
#   blender -b --factory-startup --python render_blender.py -- JOBS.json
#
# JOBS.json is an array of views: {"model": "a.glb", "out": "a.png", "width": 480, "height": 360,
# "eye": [x,y,z], "target": [x,y,z], "fov": 40, "near": 0.05} in glTF coordinates (Y up). Each is written
# as an RGBA PNG with a transparent background; exit 0 when every view was written.
#
# What is set up around the importer, and why (none of it changes what the file describes):
#   - numpy >= 1.24 removed np.bool, which Blender 3.4's glTF add-on still uses: restored before the import;
#   - glTF is Y up, Blender Z up: the importer converts (x, y, z) -> (x, -z, y), and the camera is placed the
#     same way;
#   - Cycles ignores back-face culling, so on a single-sided material (the importer sets use_backface_culling
#     from doubleSided: false) back faces are routed to a Transparent BSDF, as glTF draws nothing there;
#   - Cycles reads the importer's alpha as partial transparency; for MASK (blend_method CLIP) the alpha is
#     thresholded at the cutoff (alpha >= alphaCutoff is opaque), as the glTF specification says;
#   - one sample at the pixel centre (a pixel filter of width 0.01), no denoising: every pixel is the point
#     sample a rasterizer without antialiasing takes, so silhouettes compare pixel for pixel.
import json
import math
import sys

import numpy as np

if not hasattr(np, 'bool'):
    np.bool = bool

import bpy  # noqa: E402
from mathutils import Vector  # noqa: E402


def to_blender(p):
    return Vector((p[0], -p[2], p[1]))


def clip_alpha(mat):
    """MASK: alpha >= cutoff becomes 1, anything below 0 (Cycles would blend the raw alpha)."""
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    for node in list(nodes):
        if node.type != 'BSDF_PRINCIPLED':
            continue
        alpha = node.inputs['Alpha']
        if not alpha.is_linked:
            alpha.default_value = 1.0 if alpha.default_value >= mat.alpha_threshold else 0.0
            continue
        source = alpha.links[0].from_socket
        below = nodes.new('ShaderNodeMath')
        below.operation = 'LESS_THAN'
        below.inputs[1].default_value = mat.alpha_threshold
        keep = nodes.new('ShaderNodeMath')
        keep.operation = 'SUBTRACT'
        keep.inputs[0].default_value = 1.0
        links.new(source, below.inputs[0])
        links.new(below.outputs[0], keep.inputs[1])
        links.new(keep.outputs[0], alpha)


def hide_back_faces(mat):
    nodes, links = mat.node_tree.nodes, mat.node_tree.links
    out = next((n for n in nodes if n.type == 'OUTPUT_MATERIAL' and n.is_active_output), None)
    if out is None or not out.inputs['Surface'].is_linked:
        return
    surface = out.inputs['Surface'].links[0].from_socket
    geometry = nodes.new('ShaderNodeNewGeometry')
    transparent = nodes.new('ShaderNodeBsdfTransparent')
    mix = nodes.new('ShaderNodeMixShader')
    links.new(geometry.outputs['Backfacing'], mix.inputs['Fac'])
    links.new(surface, mix.inputs[1])
    links.new(transparent.outputs[0], mix.inputs[2])
    links.new(mix.outputs[0], out.inputs['Surface'])


def glTF_default_material():
    """A primitive without a material gets glTF's default: opaque, single-sided."""
    mat = bpy.data.materials.new('glTF default')
    mat.use_nodes = True
    mat.use_backface_culling = True
    return mat


def render(job):
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=job['model'])
    scene = bpy.context.scene
    default = None
    for obj in scene.objects:
        if obj.type == 'MESH' and not any(s.material for s in obj.material_slots):
            default = default or glTF_default_material()
            obj.data.materials.append(default)
    for mat in bpy.data.materials:
        if not mat.use_nodes:
            continue
        if mat.blend_method == 'CLIP':
            clip_alpha(mat)
        if mat.use_backface_culling:
            hide_back_faces(mat)

    cam_data = bpy.data.cameras.new('view')
    cam_data.sensor_fit = 'VERTICAL'
    cam_data.angle_y = math.radians(job['fov'])
    cam_data.clip_start = job.get('near', 0.05)
    cam_data.clip_end = 1e6
    cam = bpy.data.objects.new('view', cam_data)
    scene.collection.objects.link(cam)
    eye, target = to_blender(job['eye']), to_blender(job['target'])
    cam.location = eye
    cam.rotation_euler = (target - eye).to_track_quat('-Z', 'Y').to_euler()
    scene.camera = cam

    scene.render.engine = 'CYCLES'
    scene.cycles.device = 'CPU'
    scene.cycles.samples = 1
    scene.cycles.use_denoising = False
    scene.cycles.use_adaptive_sampling = False
    scene.cycles.pixel_filter_type = 'BOX'
    scene.cycles.filter_width = 0.01
    scene.cycles.transparent_max_bounces = 1024
    scene.cycles.max_bounces = 0
    scene.render.film_transparent = True
    scene.render.resolution_x = job['width']
    scene.render.resolution_y = job['height']
    scene.render.resolution_percentage = 100
    scene.render.image_settings.file_format = 'PNG'
    scene.render.image_settings.color_mode = 'RGBA'
    scene.render.filepath = job['out']
    bpy.ops.render.render(write_still=True)


def main():
    jobs_file = sys.argv[sys.argv.index('--') + 1]
    with open(jobs_file) as f:
        jobs = json.load(f)
    for job in jobs:
        render(job)
        print(json.dumps({'out': job['out']}), flush=True)


try:
    main()
except Exception as e:  # one line, and a failing exit code, instead of Blender's own "continue"
    sys.stderr.write(f'Error: {e}\n')
    sys.exit(1)
