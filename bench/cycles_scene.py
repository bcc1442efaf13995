# Blender script for bench/cycles: builds Luz's bench scene in Cycles (the
# same OBJ geometry, Lambertian materials, emitter or constant sky, camera and
# box filter), renders it on the CPU and writes a linear EXR.
#
#   blender -b --factory-startup -P bench/cycles_scene.py -- SCENE OUT.exr SPP RES DEPTH THREADS SEED
# SCENE: cornell or sponza. DEPTH is Luz's (Mitsuba's) max_depth: segments
# per path, so Cycles gets DEPTH - 2 bounces (0 bounces is direct light, as
# max_depth 2). Prints "cycles seconds S cpu C" (bpy.ops.render.render:
# scene sync, BVH build and sampling; wall and process CPU seconds).
import math
import os
import sys
import time

import bpy
from mathutils import Matrix, Vector

scene_name, out, spp, res, depth, threads, seed = sys.argv[sys.argv.index("--") + 1:]
spp, res, depth, threads, seed = int(spp), int(res), int(depth), int(threads), int(seed)
repo = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

bpy.ops.wm.read_factory_settings(use_empty=True)
sc = bpy.context.scene


def diffuse(name, rgb, emission=None):
    m = bpy.data.materials.new(name)
    m.use_nodes = True
    nt = m.node_tree
    nt.nodes.clear()
    out_node = nt.nodes.new("ShaderNodeOutputMaterial")
    d = nt.nodes.new("ShaderNodeBsdfDiffuse")
    d.inputs["Color"].default_value = (*rgb, 1.0)
    d.inputs["Roughness"].default_value = 0.0  # Lambertian
    shader = d.outputs["BSDF"]
    if emission:
        e = nt.nodes.new("ShaderNodeEmission")
        s = max(emission)
        e.inputs["Color"].default_value = (*(c / s for c in emission), 1.0)
        e.inputs["Strength"].default_value = s  # mesh emission: radiance = color × strength
        add = nt.nodes.new("ShaderNodeAddShader")
        nt.links.new(shader, add.inputs[0])
        nt.links.new(e.outputs["Emission"], add.inputs[1])
        # One-sided, as Luz's area emitter: the back face only reflects.
        mix = nt.nodes.new("ShaderNodeMixShader")
        nt.links.new(nt.nodes.new("ShaderNodeNewGeometry").outputs["Backfacing"], mix.inputs["Fac"])
        nt.links.new(add.outputs["Shader"], mix.inputs[1])
        nt.links.new(shader, mix.inputs[2])
        shader = mix.outputs["Shader"]
    nt.links.new(shader, out_node.inputs["Surface"])
    return m


def import_obj(path, material):
    before = set(bpy.data.objects)
    # forward Y, up Z: the file's coordinates kept as they are (no axis swap)
    bpy.ops.wm.obj_import(filepath=path, forward_axis="Y", up_axis="Z")
    for o in set(bpy.data.objects) - before:
        o.data.materials.clear()
        o.data.materials.append(material)


def camera(origin, target, up, fov_x):
    cam = bpy.data.cameras.new("cam")
    cam.sensor_fit = "HORIZONTAL"
    cam.angle = math.radians(fov_x)
    cam.clip_start, cam.clip_end = 1e-3, 1e7  # Blender's 100 would cut the box (in mm) off
    obj = bpy.data.objects.new("cam", cam)
    sc.collection.objects.link(obj)
    o, t, u = Vector(origin), Vector(target), Vector(up)
    f = (t - o).normalized()
    r = f.cross(u).normalized()
    u2 = r.cross(f)
    m = Matrix.Identity(4)
    for i in range(3):
        m[i][0], m[i][1], m[i][2], m[i][3] = r[i], u2[i], -f[i], o[i]
    obj.matrix_world = m
    sc.camera = obj


world = bpy.data.worlds.new("world")
world.use_nodes = True
bg = world.node_tree.nodes["Background"]
sc.world = world
if scene_name == "cornell":  # scenes/cornell-box.xml
    d = os.path.join(repo, "scenes", "cornell-box")
    import_obj(os.path.join(d, "white.obj"), diffuse("white", (0.725, 0.71, 0.68)))
    import_obj(os.path.join(d, "red.obj"), diffuse("red", (0.63, 0.065, 0.05)))
    import_obj(os.path.join(d, "green.obj"), diffuse("green", (0.14, 0.45, 0.091)))
    import_obj(os.path.join(d, "light.obj"), diffuse("light", (0.78, 0.78, 0.78), emission=(17.0, 12.0, 4.0)))
    camera((278, 273, -800), (278, 273, 0), (0, 1, 0), 39.3077)
    bg.inputs["Strength"].default_value = 0.0
elif scene_name == "sponza":  # bench/scenes/sponza-inside.xml
    import_obj(os.path.join(repo, "..", "shared", "scenes", "sponza-dabrovic-obj", "sponza.obj"),
               diffuse("grey", (0.6, 0.6, 0.6)))
    camera((-12, 2.5, 0), (10, 5, 0), (0, 1, 0), 70.0)
    bg.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    bg.inputs["Strength"].default_value = 1.0
else:
    sys.exit("cycles_scene.py: SCENE must be cornell or sponza")

sc.render.engine = "CYCLES"
cy = sc.cycles
cy.device = "CPU"
cy.samples = spp
cy.use_adaptive_sampling = False
cy.use_denoising = False
cy.seed = seed
cy.sampling_pattern = "PROGRESSIVE_MULTI_JITTER"  # the 3.4 default, named
bounces = max(depth - 2, 0)
cy.max_bounces = bounces
cy.diffuse_bounces = bounces
cy.glossy_bounces = bounces
cy.transmission_bounces = bounces
cy.transparent_max_bounces = bounces
cy.volume_bounces = 0
cy.sample_clamp_direct = 0.0  # no clamping: unbiased, as Luz
cy.sample_clamp_indirect = 0.0
cy.caustics_reflective = True
cy.caustics_refractive = True
cy.blur_glossy = 0.0
cy.pixel_filter_type = "BOX"
cy.filter_width = 1.0
sc.render.resolution_x = res
sc.render.resolution_y = res
sc.render.resolution_percentage = 100
sc.render.threads_mode = "FIXED"
sc.render.threads = threads
sc.render.film_transparent = False
sc.view_settings.view_transform = "Standard"
sc.view_settings.look = "None"
sc.view_settings.exposure = 0.0
sc.view_settings.gamma = 1.0
sc.render.image_settings.file_format = "OPEN_EXR"
sc.render.image_settings.color_depth = "32"
sc.render.image_settings.exr_codec = "ZIP"
sc.render.image_settings.color_mode = "RGB"

t0, c0 = time.perf_counter(), time.process_time()
bpy.ops.render.render()
seconds, cpu = time.perf_counter() - t0, time.process_time() - c0
bpy.data.images["Render Result"].save_render(out)
print(f"cycles seconds {seconds:.3f} cpu {cpu:.3f}")
