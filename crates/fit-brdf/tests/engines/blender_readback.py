# Imports glTF materials with Blender's bundled importer (io_scene_gltf2) and writes
# what it made of each as JSON (engines_blender.rs compares that with the mapping).
#
#   blender -b --factory-startup --python blender_readback.py -- OUT.json A.gltf [B.gltf ...]
#
# brdfkit's export holds a material and no mesh, and Blender's importer only creates
# the materials a mesh uses: each file is copied with one triangle (an embedded data: URI
# buffer) that uses materials[0]. The material object itself is left as exported.
# The import uses import_shading="SMOOTH" (see below): shading of the triangle only.
#
# Per file: the Principled BSDF's inputs (Base Color, Metallic, Roughness, Specular,
# Specular Tint, Sheen, Sheen Tint, Clearcoat, Clearcoat Roughness, IOR), every Velvet
# BSDF (Color, Sigma) and whether it reaches the Material Output through an Add Shader,
# and the inputs of the "glTF Material Output" group node (where 3.4 keeps
# KHR_materials_specular's original factors).
import base64
import json
import os
import struct
import sys
import tempfile

import bpy

PRINCIPLED = ["Base Color", "Metallic", "Roughness", "Specular", "Specular Tint", "Sheen",
              "Sheen Tint", "Clearcoat", "Clearcoat Roughness", "IOR"]


def with_triangle(doc):
    """The document with one triangle using materials[0] in the default scene."""
    doc = dict(doc)
    data = struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0)
    doc["buffers"] = [{"byteLength": len(data),
                       "uri": "data:application/octet-stream;base64," + base64.b64encode(data).decode()}]
    doc["bufferViews"] = [{"buffer": 0, "byteLength": len(data)}]
    doc["accessors"] = [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                         "min": [0, 0, 0], "max": [1, 1, 0]}]
    doc["meshes"] = [{"primitives": [{"attributes": {"POSITION": 0}, "material": 0}]}]
    doc["nodes"] = [{"mesh": 0}]
    doc["scenes"] = [{"nodes": [0]}]
    doc["scene"] = 0
    return doc


def value(socket):
    v = socket.default_value
    try:
        return [float(x) for x in v]
    except TypeError:
        return float(v)


def reaches_output(node, tree):
    """Whether node's shader output reaches the active Material Output through Add
    Shader nodes only."""
    for link in tree.links:
        if link.from_node != node:
            continue
        to = link.to_node
        if to.type == "OUTPUT_MATERIAL" and to.is_active_output:
            return True
        if to.type == "ADD_SHADER" and reaches_output(to, tree):
            return True
    return False


def read_material(mat):
    tree = mat.node_tree
    out = {"name": mat.name, "principled": None, "velvet": [], "gltf_output": None}
    for node in tree.nodes:
        if node.type == "BSDF_PRINCIPLED":
            out["principled"] = {k: value(node.inputs[k]) for k in PRINCIPLED}
            out["principled_linked"] = sorted(s.name for s in node.inputs if s.is_linked)
            out["principled_reaches_output"] = reaches_output(node, tree)
        elif node.type == "BSDF_VELVET":
            out["velvet"].append({"Color": value(node.inputs["Color"]),
                                  "Sigma": value(node.inputs["Sigma"]),
                                  "reaches_output": reaches_output(node, tree)})
        elif node.type == "GROUP" and node.node_tree and node.node_tree.name == "glTF Material Output":
            out["gltf_output"] = {s.name: value(s) for s in node.inputs if hasattr(s, "default_value")}
    return out


def main():
    argv = sys.argv[sys.argv.index("--") + 1:]
    out_path, files = argv[0], argv[1:]
    results = []
    tmp = tempfile.mkdtemp()
    for i, path in enumerate(files):
        with open(path) as f:
            doc = json.load(f)
        bpy.ops.wm.read_factory_settings(use_empty=True)
        wrapped = os.path.join(tmp, "%d.gltf" % i)
        with open(wrapped, "w") as f:
            json.dump(with_triangle(doc), f)
        # import_shading's default ("NORMALS") runs numpy's np.bool, gone since numpy
        # 1.24, which Debian 12 ships beside Blender 3.4.1: "SMOOTH" skips that code.
        bpy.ops.import_scene.gltf(filepath=wrapped, import_shading="SMOOTH")
        name = doc["materials"][0].get("name")
        mats = [m for m in bpy.data.materials if m.name == name and m.use_nodes]
        results.append({"file": path, "blender": bpy.app.version_string,
                        "importer": ".".join(map(str, __import__("io_scene_gltf2").bl_info["version"])),
                        "materials": [read_material(m) for m in mats]})
    with open(out_path, "w") as f:
        json.dump(results, f, indent=1)


main()
